"""muscle_sim: one McKibben muscle (``MuscleModel``), ground truth on ``sim/muscle_N/state``.

Inputs: ``valve_N/pressure`` (absolute Pa) and ``sim/pulley/state`` (joint ``muscle_N``:
contraction x in m). Output: MuscleState with the contraction x the force was evaluated at and
the stiffness -dF/dx the loading servo uses for implicit coupling.

With ``chained`` the muscle steps to t_k on the valve's pressure of the same exchange (see
``nodes.base``) and publishes one state per pressure sample, stamped like it; between exchanges
the end yields with ``holder_compliance_m_per_n`` (``MuscleModel.step_compliant``).
"""

from __future__ import annotations

from typing import Any

from pam_bench_interfaces.msg import MuscleState
from sensor_msgs.msg import FluidPressure, JointState

from pam_bench.models.muscle import MuscleModel, MuscleParams
from pam_bench.nodes.base import BenchNode, ns_of, run_node, time_of
from pam_bench.nodes.valve_sim import ATMOSPHERE_PA

__all__ = ['MuscleSim', 'main']


class MuscleSim(BenchNode):
    """Thin node over ``MuscleModel``."""

    LEAN_SPIN = True    # subscriptions only: see nodes.base.lean_spin

    def __init__(self, name: str = 'muscle_1', **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self.channel = self.declare_typed('channel', 1, 'muscle channel N', '-', 1, 2)
        self.chained = self.declare_typed('chained', False, 'step on the pressure of the same '
                                          'exchange (Gauss-Seidel chain valve -> muscle)')
        self.compliance_m_per_n = self.declare_typed(
            'holder_compliance_m_per_n', 1.0e-6, 'compliance of the holder of the muscle end '
            'between exchanges (belt + drive), used for pressure samples', 'm/N', 0.0, 1.0)
        self.model = MuscleModel(self.declare_model('muscle', MuscleParams))
        self.joint = f'muscle_{self.channel}'
        self.p_topic = f'valve_{self.channel}/pressure'
        self.x_topic = 'sim/pulley/state'
        self.pressure_pa = 0.0
        self.contraction_m = 0.0
        self.pub = self.create_step_publisher(MuscleState, f'sim/muscle_{self.channel}/state')
        self.force_n = 0.0
        self.sync_input(FluidPressure, self.p_topic, same_step=self.chained,
                        samples=self.chained)
        self.sync_input(JointState, self.x_topic)
        self.start_lockstep()

    def on_step(self, t_ns: int, dt_s: float, inputs: dict[str, Any]) -> None:
        """Evaluate the muscle at the last pressure (every pressure sample when chained) and
        contraction."""
        pressures: list[tuple[int, float]] = []
        if self.p_topic in inputs:
            msgs = inputs[self.p_topic]
            for m in msgs if isinstance(msgs, list) else [msgs]:
                pressures.append((ns_of(m.header.stamp), m.fluid_pressure - ATMOSPHERE_PA))
        if self.x_topic in inputs:
            js = inputs[self.x_topic]
            x = js.position[list(js.name).index(self.joint)]
            if self.finite(x):
                self.contraction_m = x
            else:
                self.reject('muscle contraction', x)
        if not self.chained or not pressures:
            pressures = [(t_ns, pressures[-1][1] if pressures else self.pressure_pa)]
        c = self.compliance_m_per_n if len(pressures) > 1 else 0.0
        for stamp, p in pressures:
            if not self.finite(p):
                self.reject('muscle pressure', p)
                p = self.pressure_pa
            self.pressure_pa = p
            out, x = self.model.step_compliant(p, self.contraction_m, self.force_n, c)
            msg = MuscleState(pressure=p, force=out.force_n, contraction=x, volume=out.volume_m3,
                              stiffness=out.stiffness_n_per_m, friction_force=out.friction_n)
            msg.header.stamp = time_of(stamp)
            msg.header.frame_id = self.joint
            self.pub.publish(msg)
        self.force_n = out.force_n


def main(args: list[str] | None = None) -> None:
    """Run the node."""
    run_node(MuscleSim, args)


if __name__ == '__main__':
    main()
