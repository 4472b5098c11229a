"""valve_sim: the proportional pressure valve of one muscle channel (``ValveModel``).

Subscribes ``valve_N/command`` (ValveCommand, V) and ``sim/muscle_N/state`` (chamber volume);
publishes ``valve_N/pressure`` (FluidPressure, absolute Pa, at the end of each exchange) and
``sim/valve_N/samples`` (PressureSamples: the gauge pressure at the end of every sub-step of
the exchange, ``sub_step_s`` long, or the command's ``sample_period`` during a 1 kHz record),
which the muscle follows sample by sample. A NaN, infinite or out-of-range voltage is rejected,
counted on /diagnostics and the valve vents (u = 0 V) until a valid command arrives. While the
pressure is in transient, until an exchange since its last command change has shown the
chamber volume standing still, the valve asks for exchange steps of at most
``transient_step_s`` (it integrates an exchange at the volume of its start). On a wall clock
(``lockstep: false``) it steps at ``rate_hz`` with the latest command and chamber volume.
"""

from __future__ import annotations

from typing import Any

from diagnostic_msgs.msg import DiagnosticStatus
from pam_bench_interfaces.msg import MuscleState, PressureSamples, ValveCommand
from sensor_msgs.msg import FluidPressure

from pam_bench.config import topics
from pam_bench.config.settings import ValveSettings
from pam_bench.models.constants import ATMOSPHERE_PA
from pam_bench.models.coupling import substep_grid
from pam_bench.models.valve import ValveModel, VolumeEvidence
from pam_bench.runtime.base import RELIABLE, BenchNode
from pam_bench.runtime.messages import floats
from pam_bench.runtime.process import run_node
from pam_bench.runtime.stamped import stamped

__all__ = ['ValveSim', 'main']



class ValveSim(BenchNode):
    """Thin node over ``ValveModel``."""

    SETTINGS = ValveSettings

    def __init__(self, name: str = 'valve_1', **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        s: ValveSettings = self.settings
        self.channel = s.channel
        self.frame_id = f'valve_{self.channel}'
        self.sync_command = s.sync_command
        self.sub_step_s = s.sub_step_s
        self.model = ValveModel(s.valve)
        self.voltage_v = 0.0
        self.sample_period_s = 0.0
        self.volume_m3: float | None = None
        self.evidence = VolumeEvidence()
        self.cmd_topic = topics.valve_command(self.channel)
        self.muscle_topic = topics.muscle_state(self.channel)
        self.pub = self.create_step_publisher(FluidPressure, topics.valve_pressure(self.channel))
        self.samples_pub = self.create_step_publisher(PressureSamples,
                                                      topics.valve_samples(self.channel))
        if self.lockstep and self.sync_command:
            self.sync_input(ValveCommand, self.cmd_topic)
        else:
            self.create_subscription(ValveCommand, self.cmd_topic, self.apply_command, RELIABLE)
        self.sync_input(MuscleState, self.muscle_topic, from_start=True)
        self.start_stepping()

    def apply_command(self, msg: ValveCommand) -> None:
        """Accept a voltage in [0, u_max] V; anything else vents the valve."""
        u = msg.voltage
        if self.fault_active('valve_stuck'):          # an injected fault: commands ignored
            return
        if not self.finite(u) or not 0.0 <= u <= self.model.p.voltage_max_v:
            self.reject(f'valve_{self.channel} voltage (valve vents)', u)
            self.voltage_v = 0.0
            self.sample_period_s = 0.0
            return
        t = msg.sample_period
        self.sample_period_s = float(t) if self.finite(t) and 0.0 < t <= 1.0 else 0.0
        self.voltage_v = float(u)

    def on_step(self, t_ns: int, dt_s: float, inputs: dict[str, Any]) -> None:
        """Advance the valve over the exchange and publish its pressure and samples."""
        t0_s = (t_ns - round(dt_s * 1e9)) * 1e-9            # the inputs' stamp
        if self.cmd_topic in inputs:
            before = self.voltage_v
            self.apply_command(inputs[self.cmd_topic])
            if self.voltage_v != before:
                self.evidence.command_changed(t0_s)
        if self.muscle_topic in inputs:
            v = inputs[self.muscle_topic].volume
            if self.finite(v) and v > 0.0:
                self.volume_m3 = v
                self.evidence.volume(t0_s, v)
        record = self.sample_period_s > 0.0
        steps = substep_grid(dt_s, min(self.sample_period_s if record else self.sub_step_s,
                                       dt_s))
        pressures = self.model.samples(self.voltage_v, steps, self.volume_m3)
        frame = self.frame_id
        reported = self.faulty(pressures[-1] + ATMOSPHERE_PA)   # injected faults (wall clock)
        if reported is not None:
            self.pub.publish(stamped(FluidPressure, t_ns, frame, fluid_pressure=reported,
                                     variance=0.0))
        self.samples_pub.publish(stamped(PressureSamples, t_ns, frame, step=floats(steps),
                                         pressure=floats(pressures), record=record))
        self.max_next_step_s = self.model.max_step(self.voltage_v, self.evidence)

    def safe_state(self) -> None:
        """Vent: 0 V, the chamber at atmosphere."""
        self.voltage_v = 0.0
        self.model.reset(0.0)

    def publish_safe_state(self) -> None:
        """The vented chamber's pressure, one atmosphere, stamped now."""
        self.pub.publish(stamped(FluidPressure, self.now_ns(), self.frame_id,
                                 fluid_pressure=ATMOSPHERE_PA, variance=0.0))

    def on_fault(self, reason: str) -> None:
        """Vent."""
        self.safe_state()
        self.diagnose(DiagnosticStatus.ERROR, f'valve vented: {reason}')


def main(args: list[str] | None = None) -> None:
    """Run the node."""
    run_node(ValveSim, args)


if __name__ == '__main__':
    main()
