"""muscle_sim: one McKibben muscle (``MuscleModel``), ground truth on ``sim/muscle_N/state``.

Inputs: ``valve_N/pressure`` (absolute Pa) and ``sim/pulley/state`` (joint ``muscle_N``:
contraction x in m). Output: MuscleState with the contraction x the force was evaluated at and
the stiffness -dF/dx the loading servo uses for implicit coupling.
"""

from __future__ import annotations

from typing import Any

from pam_bench_interfaces.msg import MuscleState
from sensor_msgs.msg import FluidPressure, JointState

from pam_bench.models.muscle import MuscleModel, MuscleParams
from pam_bench.nodes.base import RELIABLE, BenchNode, run_node, time_of
from pam_bench.nodes.valve_sim import ATMOSPHERE_PA

__all__ = ['MuscleSim', 'main']


class MuscleSim(BenchNode):
    """Thin node over ``MuscleModel``."""

    LEAN_SPIN = True    # subscriptions only: see nodes.base.lean_spin

    def __init__(self, name: str = 'muscle_1', **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self.channel = self.declare_typed('channel', 1, 'muscle channel N', '-', 1, 2)
        self.model = MuscleModel(self.declare_model('muscle', MuscleParams))
        self.joint = f'muscle_{self.channel}'
        self.p_topic = f'valve_{self.channel}/pressure'
        self.x_topic = 'sim/pulley/state'
        self.pressure_pa = 0.0
        self.contraction_m = 0.0
        self.pub = self.create_publisher(MuscleState, f'sim/muscle_{self.channel}/state',
                                         RELIABLE)
        self.sync_input(FluidPressure, self.p_topic)
        self.sync_input(JointState, self.x_topic)
        self.start_lockstep()

    def on_step(self, t_ns: int, dt_s: float, inputs: dict[str, Any]) -> None:
        """Evaluate the muscle at the last pressure and contraction."""
        if inputs:
            p = inputs[self.p_topic].fluid_pressure - ATMOSPHERE_PA
            js = inputs[self.x_topic]
            x = js.position[list(js.name).index(self.joint)]
            if not self.finite(p, x):
                self.reject('muscle input', (p, x))
            else:
                self.pressure_pa, self.contraction_m = p, x
        out = self.model.step(self.pressure_pa, self.contraction_m)
        msg = MuscleState(pressure=self.pressure_pa, force=out.force_n,
                          contraction=self.contraction_m, volume=out.volume_m3,
                          stiffness=out.stiffness_n_per_m, friction_force=out.friction_n)
        msg.header.stamp = time_of(t_ns)
        msg.header.frame_id = self.joint
        self.pub.publish(msg)


def main(args: list[str] | None = None) -> None:
    """Run the node."""
    run_node(MuscleSim, args)


if __name__ == '__main__':
    main()
