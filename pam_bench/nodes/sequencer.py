"""sequencer: runs a characterisation protocol over the measured topics only.

Reads ``load_cell_N/force``, ``encoder/joint_state`` and ``valve_N/pressure``; commands
``valve_N/command`` and ``loading_servo/command`` at every step; publishes one
``protocol/point`` at the end of every dwell and ``protocol/status``. The protocol logic is the
pure ``pam_bench.models.protocols.Sequencer``; this node only ticks it.
"""

from __future__ import annotations

import pathlib
from typing import Any

import yaml
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import WrenchStamped
from pam_bench_interfaces.msg import CharacteristicPoint, LoadCommand, ProtocolStatus, ValveCommand
from sensor_msgs.msg import FluidPressure, JointState

from pam_bench.models.protocols import Measurement, Phase, Point, Sequencer, schedule_from_config
from pam_bench.nodes.base import RELIABLE, BenchNode, run_node, time_of
from pam_bench.nodes.valve_sim import ATMOSPHERE_PA

__all__ = ['SequencerNode', 'main']

END_CODES = {Phase.DONE: 0, Phase.ABORTED: 4, Phase.CANCELLED: 5}
STATE_OF = {Phase.IDLE: ProtocolStatus.STATE_IDLE, Phase.SETTLE: ProtocolStatus.STATE_RUNNING,
            Phase.DWELL: ProtocolStatus.STATE_RUNNING, Phase.DONE: ProtocolStatus.STATE_DONE,
            Phase.ABORTED: ProtocolStatus.STATE_ABORTED,
            Phase.CANCELLED: ProtocolStatus.STATE_CANCELLED}


def default_protocols_file() -> str:
    """config/protocols.yaml of the source tree or of the installed share directory."""
    here = pathlib.Path(__file__).resolve().parents[2] / 'config' / 'protocols.yaml'
    if here.exists():
        return str(here)
    try:
        from ament_index_python.packages import get_package_share_directory
        return str(pathlib.Path(get_package_share_directory('pam_bench')) / 'config'
                   / 'protocols.yaml')
    except Exception:  # noqa: BLE001 - fall back to the relative path
        return 'config/protocols.yaml'


class SequencerNode(BenchNode):
    """Thin node over ``protocols.Sequencer``."""

    def __init__(self, name: str = 'sequencer', **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self.channel = self.declare_typed('channel', 1, 'muscle channel under test', '-', 1, 2)
        self.protocol = self.declare_typed('protocol', 'demo', 'protocol name to run')
        path = self.declare_typed('protocols_file', default_protocols_file(),
                                  'YAML file of the protocols')
        self.stop_on_end = self.declare_typed('stop_on_end', True,
                                              'ask the sim clock to end the run with the protocol')
        self.status_period_s = self.declare_typed('status_period_s', 1.0,
                                                  'sim time between status messages', 's',
                                                  1e-3, 1e6)
        with open(path, encoding='utf-8') as fh:
            table = yaml.safe_load(fh) or {}
        if self.protocol not in table:
            raise KeyError(f'protocol {self.protocol!r} is not in {path}')
        readings, settle = schedule_from_config(self.protocol, table[self.protocol])
        self.core = Sequencer(self.protocol, readings, settle)
        self.pulley_radius_m = self.declare_typed(
            'pitch_diameter_m', 0.06366, 'pulley pitch diameter for x = r theta', 'm',
            1e-3, 10.0) / 2.0
        ch = self.channel
        self.cell_topic = f'load_cell_{ch}/force'
        self.enc_topic = 'encoder/joint_state'
        self.p_topic = f'valve_{ch}/pressure'
        self.meas = Measurement(0.0, 0.0, 0.0)
        self.valve_pub = self.create_publisher(ValveCommand, f'valve_{ch}/command', RELIABLE)
        self.load_pub = self.create_publisher(LoadCommand, 'loading_servo/command', RELIABLE)
        self.point_pub = self.create_publisher(CharacteristicPoint, 'protocol/point', RELIABLE)
        self.status_pub = self.create_publisher(ProtocolStatus, 'protocol/status', RELIABLE)
        self._last_status_t = -1e300
        self._last_phase = Phase.IDLE
        self.sync_input(WrenchStamped, self.cell_topic)
        self.sync_input(JointState, self.enc_topic)
        self.sync_input(FluidPressure, self.p_topic)
        self.start_lockstep()

    def on_start(self, t_ns: int) -> None:
        """Start the protocol at t_0."""
        self.core.start(t_ns * 1e-9)

    def on_step(self, t_ns: int, dt_s: float, inputs: dict[str, Any]) -> None:
        """Tick the protocol and publish commands, the point and the status."""
        if inputs:
            f = inputs[self.cell_topic].wrench.force.x
            th = inputs[self.enc_topic].position[0]
            p = inputs[self.p_topic].fluid_pressure - ATMOSPHERE_PA
            self.meas = Measurement(f, th * self.pulley_radius_m, p)
        t = t_ns * 1e-9
        cmd = self.core.tick(t, self.meas)
        stamp = time_of(t_ns)
        v = ValveCommand(voltage=cmd.voltage_v)
        v.header.stamp = stamp
        self.valve_pub.publish(v)
        lc = LoadCommand(mode=int(cmd.load_mode), channel=self.channel, setpoint=cmd.load_value)
        lc.header.stamp = stamp
        self.load_pub.publish(lc)
        if cmd.point is not None:
            self.point_pub.publish(self._point_msg(cmd.point, stamp))
        if self.core.phase != self._last_phase or t - self._last_status_t >= self.status_period_s:
            self._publish_status(t, stamp)
        if self.core.phase in END_CODES and self.stop_on_end:
            self.stop_request = (END_CODES[self.core.phase],
                                 f'protocol {self.core.name} {self.core.phase.value}'
                                 + (f': {self.core.reason}' if self.core.reason else ''))

    def _point_msg(self, pt: Point, stamp: Any) -> CharacteristicPoint:
        r, m = pt.reading, pt.measurement
        msg = CharacteristicPoint(protocol=r.protocol, series=r.series, step=r.step,
                                  direction=int(r.direction), series_value=r.series_value,
                                  set_value=r.set_value, voltage=pt.voltage_v, force=m.force_n,
                                  contraction=m.contraction_m, pressure=m.pressure_pa)
        msg.header.stamp = stamp
        return msg

    def _publish_status(self, t: float, stamp: Any) -> None:
        c = self.core
        total = len(c.readings)
        msg = ProtocolStatus(protocol=c.name, state=STATE_OF[c.phase], phase=c.phase.value,
                             points_done=c.points_done, points_total=total,
                             progress=c.points_done / total, elapsed=t - c.t_start,
                             remaining=c.remaining_s(t), reason=c.reason)
        msg.header.stamp = stamp
        self.status_pub.publish(msg)
        self._last_status_t = t
        self._last_phase = c.phase

    def on_fault(self, reason: str) -> None:
        """Abort: the next tick vents the valve."""
        self.core.stop(Phase.ABORTED, reason)
        self.diagnose(DiagnosticStatus.ERROR, f'protocol aborted: {reason}')


def main(args: list[str] | None = None) -> None:
    """Run the node."""
    run_node(SequencerNode, args)


if __name__ == '__main__':
    main()
