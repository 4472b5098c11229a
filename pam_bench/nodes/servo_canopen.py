"""servo_canopen: the driver of the loading servo's CiA 402 drive on CAN.

Thin node over ``buses.canopen_drive``: it configures the drive at start (SDO, PDO mapping,
NMT), then every ``1 / rate_hz`` s sends RPDO 1 (controlword and set value) and publishes the
drive's actuals as ``loading_servo/state`` (joint ``motor``: motor-side angle, torque), as
the simulated loading servo does. Input ``loading_servo/command`` (LoadCommand): off, a muscle
tension (N) or a contraction (m); a command that is not finite, of an unknown mode or out of
range is rejected and the last valid one kept (``docs/drivers.md``); until the first,
``initial_mode`` and ``initial_setpoint`` (the torque servo's drive holds the pulley from t_0).

Watching, on ``/diagnostics`` (concern ``drive``): the power state; an EMCY is an ERROR and
the drive is left disabled until ``loading_servo/reset`` (std_srvs/Trigger); no heartbeat for
``heartbeat_timeout_s`` is STALE, the driver sends quick stop. While the drive is silent, in
fault or in quick stop no state is published: the sequencer's ``drive`` input goes stale and a
suspender on it suspends the run (``protocol.suspenders``) until the drive follows again.
The python-can interface is a setting: ``socketcan`` on a lab's bench, ``socketcand`` against
the hub of ``pam-bench emulate --buses`` (``buses.can_hub``: why not vcan or udp_multicast).
"""

from __future__ import annotations

import math
import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticStatus
from pam_bench_interfaces.msg import LoadCommand
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger

from pam_bench.buses.can_hub import bus_config
from pam_bench.buses.canopen_drive import CanopenDrive, eds_path
from pam_bench.buses.cia402 import State
from pam_bench.buses.errors import BusUnreachable
from pam_bench.config import topics
from pam_bench.config.settings import ServoCanopenSettings
from pam_bench.models.loading_servo import LoadMode
from pam_bench.runtime.base import SENSOR, BenchNode
from pam_bench.runtime.core import Spin
from pam_bench.runtime.process import run_node
from pam_bench.runtime.stamped import stamped

__all__ = ['ServoCanopenNode', 'main']

RESET = 'loading_servo/reset'
"""Service that clears a drive fault the driver keeps."""
UNFIT = (State.FAULT, State.FAULT_REACTION_ACTIVE, State.QUICK_STOP_ACTIVE)
"""Power states in which the drive does not follow its set value (no state is published)."""


class ServoCanopenNode(BenchNode):
    """Thin node over ``CanopenDrive`` (module docstring)."""

    SETTINGS = ServoCanopenSettings

    def __init__(self, name: str = 'servo_canopen', **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        s: ServoCanopenSettings = self.settings
        self.drive = CanopenDrive(bus_config(s.can_interface, s.can_channel, s.can_port),
                                  s.node_id, s.eds_file or eds_path(), s.drive, s.heartbeat_ms,
                                  s.heartbeat_timeout_s)
        self.drive.command(LoadMode(s.initial_mode), s.initial_setpoint)
        self._state: State | None = None
        self._stale = False
        self.state_pub = self.create_step_publisher(JointState, topics.LOAD_STATE)
        self.create_subscription(LoadCommand, topics.LOAD_COMMAND, self._command, SENSOR)
        self.create_service(Trigger, RESET, self._on_reset)
        self.start_wall_ticks(1.0 / s.rate_hz)

    def spin_mode(self) -> Spin:
        """On a deadline, its reset service served between ticks."""
        return Spin.DEADLINE

    def _command(self, msg: LoadCommand) -> None:
        """A load command: kept for the next tick; a bad one is rejected (last one kept)."""
        value = float(msg.setpoint)
        modes = {LoadCommand.MODE_OFF: LoadMode.OFF, LoadCommand.MODE_FORCE: LoadMode.FORCE,
                 LoadCommand.MODE_POSITION: LoadMode.POSITION}
        mode = modes.get(msg.mode)
        limit = 3000.0 if mode == LoadMode.FORCE else 0.5
        if mode is None or not math.isfinite(value) or abs(value) > limit:
            self.reject('load command', (msg.mode, value))
            return
        self.drive.command(mode, value)

    def _on_reset(self, request: Trigger.Request, response: Trigger.Response
                  ) -> Trigger.Response:
        """Clear a kept fault: the drive is reset at the next ticks."""
        response.success = bool(self.drive.fault)
        response.message = f'cleared: {self.drive.fault}' if self.drive.fault else 'no fault'
        self.drive.reset()
        return response

    def on_wall_tick(self, t_ns: int | None = None) -> None:
        """One exchange: RPDO out, the drive's state and actuals in and published."""
        self.count_tick()
        now = time.monotonic()
        try:
            self.drive.tick(now)
        except BusUnreachable as exc:             # the bus itself is gone: nothing to send
            self.diagnose(DiagnosticStatus.STALE, f'{exc}: no set value reaches the drive '
                          '(a drive consuming the master heartbeat, 0x1016, stops itself)',
                          'drive')
            return
        stale = self.drive.stale(now)
        if stale != self._stale:
            self._stale = stale
            if stale:
                self.diagnose(DiagnosticStatus.STALE, 'drive silent (no heartbeat for '
                              f'{self.drive.heartbeat_timeout_s:g} s): quick stop sent',
                              'drive')
        if self.drive.fault:
            self.diagnose(DiagnosticStatus.ERROR, f'drive fault: {self.drive.fault}; '
                          'disabled until loading_servo/reset', 'drive')
        elif not stale and self.drive.state != self._state:
            self._state = self.drive.state
            self.diagnose(DiagnosticStatus.OK, f'drive {self.drive.state.value}', 'drive')
        if stale or self.drive.fault or self.drive.last_tpdo_s is None \
                or self.drive.state in UNFIT:
            return                   # a drive that cannot follow has no state to publish
        s = self.drive.scale
        angle = s.angle_of(self.drive.position_counts)
        torque = self.drive.torque_permille * 1e-3 * s.rated_torque_nm
        self.state_pub.publish(stamped(JointState, self.now_ns(), name=[topics.MOTOR_JOINT],
                                       position=[angle * s.gear_ratio], velocity=[0.0],
                                       effort=[torque]))

    def configure_device(self) -> str:
        """Configure: the drive set up over SDO (PDO mapping, heartbeat, mode) and started
        (NMT); returns why it could not be ('' when it was)."""
        try:
            self.drive.start()
        except BusUnreachable as exc:
            return str(exc)
        return ''

    def on_fault(self, reason: str) -> None:
        """A failed tick: the drive off."""
        self.drive.command(LoadMode.OFF, 0.0)

    def safe_state(self) -> None:
        """The drive off, sent now (shutdown: its power stage off)."""
        self.drive.command(LoadMode.OFF, 0.0)
        if self.drive.network is None:
            return                   # never configured: nothing to send
        try:
            self.drive.tick(time.monotonic())
        except BusUnreachable:
            pass                     # a drive consuming the master heartbeat stops itself

    def destroy_node(self) -> None:
        """Turn the drive off and leave the bus, then go."""
        self.drive.stop()
        super().destroy_node()


def main(args: list[str] | None = None) -> None:
    """Run the node."""
    run_node(ServoCanopenNode, args)


if __name__ == '__main__':
    main()
