"""valve_sim: the proportional pressure valve of one muscle channel (``ValveModel``).

Subscribes ``valve_N/command`` (ValveCommand, V) and ``sim/muscle_N/state`` (chamber volume);
publishes ``valve_N/pressure`` (FluidPressure, absolute Pa). A NaN, infinite or out-of-range
voltage is rejected, counted on /diagnostics and the valve vents (u = 0 V) until a valid
command arrives. When the command asks for a ``sample_period`` T shorter than the exchange
step h, the step is integrated in round(h / T) equal sub-steps and every sub-step's pressure is
published, stamped at its own time (the last on the exchange grid); the muscle and the load
cell of a chained scene follow each sample (1 kHz step records at 10 ms exchanges).
"""

from __future__ import annotations

from typing import Any

from diagnostic_msgs.msg import DiagnosticStatus
from pam_bench_interfaces.msg import MuscleState, ValveCommand
from sensor_msgs.msg import FluidPressure

from pam_bench.models.valve import ValveModel, ValveParams, sub_steps
from pam_bench.nodes.base import RELIABLE, BenchNode, run_node, time_of

__all__ = ['ValveSim', 'ATMOSPHERE_PA', 'main']

ATMOSPHERE_PA = 101325.0


class ValveSim(BenchNode):
    """Thin node over ``ValveModel``."""

    LEAN_SPIN = True    # subscriptions only: see nodes.base.lean_spin

    def __init__(self, name: str = 'valve_1', **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self.channel = self.declare_typed('channel', 1, 'muscle channel N', '-', 1, 2)
        self.sync_command = self.declare_typed(
            'sync_command', True, 'require a command at every step (lock-step controllers)')
        self.model = ValveModel(self.declare_model('valve', ValveParams))
        self.voltage_v = 0.0
        self.sample_period_s = 0.0
        self.volume_m3: float | None = None
        self.cmd_topic = f'valve_{self.channel}/command'
        self.muscle_topic = f'sim/muscle_{self.channel}/state'
        self.pub = self.create_step_publisher(FluidPressure, f'valve_{self.channel}/pressure')
        if self.lockstep and self.sync_command:
            self.sync_input(ValveCommand, self.cmd_topic)
        else:
            self.create_subscription(ValveCommand, self.cmd_topic, self.apply_command, RELIABLE)
        if self.lockstep:
            self.sync_input(MuscleState, self.muscle_topic)
            self.start_lockstep()

    def apply_command(self, msg: ValveCommand) -> None:
        """Accept a voltage in [0, u_max] V; anything else vents the valve."""
        u = msg.voltage
        if not self.finite(u) or not 0.0 <= u <= self.model.p.voltage_max_v:
            self.reject(f'valve_{self.channel} voltage (valve vents)', u)
            self.voltage_v = 0.0
            self.sample_period_s = 0.0
            return
        t = msg.sample_period
        self.sample_period_s = float(t) if self.finite(t) and 0.0 < t <= 1.0 else 0.0
        self.voltage_v = float(u)

    def on_step(self, t_ns: int, dt_s: float, inputs: dict[str, Any]) -> None:
        """Advance the valve and publish its pressure."""
        if self.cmd_topic in inputs:
            self.apply_command(inputs[self.cmd_topic])
        if self.muscle_topic in inputs:
            self.volume_m3 = inputs[self.muscle_topic].volume
        n = sub_steps(dt_s, self.sample_period_s)
        t0 = t_ns - round(dt_s * 1e9)
        for j in range(1, n + 1):
            p = self.model.step(self.voltage_v, dt_s / n, self.volume_m3)
            msg = FluidPressure(fluid_pressure=p + ATMOSPHERE_PA, variance=0.0)
            msg.header.stamp = time_of(t_ns if j == n else t0 + (t_ns - t0) * j // n)
            msg.header.frame_id = f'valve_{self.channel}'
            self.pub.publish(msg)
        self.max_next_step_s = self.model.max_step(self.voltage_v)

    def on_fault(self, reason: str) -> None:
        """Vent."""
        self.voltage_v = 0.0
        self.model.reset(0.0)
        self.diagnose(DiagnosticStatus.ERROR, f'valve vented: {reason}')


def main(args: list[str] | None = None) -> None:
    """Run the node."""
    run_node(ValveSim, args)


if __name__ == '__main__':
    main()
