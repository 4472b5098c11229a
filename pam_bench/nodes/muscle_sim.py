"""muscle_sim: one muscle (``muscle.kind``: ``models.bench_muscle``), truth on sim/muscle_N/state.

Inputs: ``sim/valve_N/samples`` (the valve's pressure at every sub-step of this exchange) and
``sim/pulley/law`` (DriveLaw of the previous exchange: how the loading servo moves the muscle
end under a force). The muscle and the drive are solved together at every sub-step
(``pam_bench.models.coupling``; a settled muscle is held for the rest of the exchange, ``settle``
settings). Outputs: ``sim/muscle_N/state`` (MuscleState at the end of the
exchange: pressure, force, contraction, chamber volume for the valve) and
``sim/muscle_N/samples`` (MuscleSamples: every sub-step's force and contraction, which the
loading servo replays and the load cell measures). On a wall clock it steps at ``rate_hz``
over its own sub-steps with the latest valve pressure held and the latest drive law.
"""

from __future__ import annotations

import math
from typing import Any

from pam_bench_interfaces.msg import DriveLaw, MuscleSamples, MuscleState, PressureSamples

from pam_bench.config import topics
from pam_bench.config.settings import MuscleSettings
from pam_bench.models.bench_muscle import make_muscle
from pam_bench.models.constants import SUB_STEP_S
from pam_bench.models.coupling import solve_substeps, substep_grid
from pam_bench.models.errors import ModelError
from pam_bench.models.loading_servo import IdealHold, drive_from_law
from pam_bench.runtime.base import BenchNode
from pam_bench.runtime.messages import floats
from pam_bench.runtime.process import run_node
from pam_bench.runtime.stamped import stamped

__all__ = ['MuscleSim', 'main']


class MuscleSim(BenchNode):
    """Thin node over the bench muscle and the coupled sub-step solve."""

    SETTINGS = MuscleSettings

    def __init__(self, name: str = 'muscle_1', **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        s: MuscleSettings = self.settings
        self.channel = s.channel
        self.model = make_muscle(s.muscle, s.straight_fibre, s.laws)
        self.joint = f'muscle_{self.channel}'
        self.p_topic = topics.valve_samples(self.channel)
        self.law_topic = topics.PULLEY_LAW
        self.pressure_pa = 0.0
        self.contraction_m = 0.0
        self.force_n = 0.0
        self._drive_cache: dict = {}
        self._mounted = False
        self.pub = self.create_step_publisher(MuscleState, topics.muscle_state(self.channel))
        self.samples_pub = self.create_step_publisher(MuscleSamples,
                                                      topics.muscle_samples(self.channel))
        self.sync_input(PressureSamples, self.p_topic, same_step=True)
        self.sync_input(DriveLaw, self.law_topic, from_start=True)
        self.start_stepping()

    def on_start(self, t_ns: int) -> None:
        """Publish the state at t_0 (the valve needs the chamber volume of step 1); the muscle
        is mounted, relaxed, where the holder's law of t_0 puts its end (first step)."""
        out = self.model.step(self.pressure_pa, self.contraction_m)
        self._publish(t_ns, out.stiffness_n_per_m, out.friction_n)

    def wall_inputs(self, inputs: dict[str, Any], dt_s: float) -> dict[str, Any]:
        """The latest valve pressure held over this step's own sub-steps."""
        last: PressureSamples = inputs[self.p_topic]
        steps = substep_grid(dt_s, SUB_STEP_S)
        inputs[self.p_topic] = PressureSamples(step=steps,
                                               pressure=[last.pressure[-1]] * len(steps))
        return inputs

    def _holder(self, law: DriveLaw) -> Any:
        if len(law.hold_contraction):
            if len(law.hold_contraction) < self.channel:
                raise ModelError(f'drive law holds {len(law.hold_contraction)} muscles, not '
                                 f'channel {self.channel}')
            return IdealHold(law.hold_contraction[self.channel - 1], law.belt_stiffness)
        return drive_from_law(list(law.parameters), list(law.state), law.mode,
                                          law.setpoint, self._drive_cache)

    def on_step(self, t_ns: int, dt_s: float, inputs: dict[str, Any]) -> None:
        """Solve the muscle with its holder over the valve's sub-steps; publish the samples."""
        samples: PressureSamples = inputs[self.p_topic]
        steps, pressures = list(samples.step), list(samples.pressure)
        if not all(map(math.isfinite, pressures)):       # (floats: a float64[] field)
            for i, p in enumerate(pressures):
                if not self.finite(p):
                    self.reject('muscle pressure (last valid held)', p)
                    pressures[i] = pressures[i - 1] if i else self.pressure_pa
        holder = self._holder(inputs[self.law_topic])
        if not self._mounted:                 # mounted slack, where the holder puts the end
            holder.prepare(steps[0])
            self.contraction_m = holder.contraction(0.0)
            self.model.reset(self.contraction_m, 0.0)
            self._mounted = True
        res = solve_substeps(self.model, holder, steps, pressures, self.force_n,
                             self.settings.settle)
        self.pressure_pa = pressures[-1]
        self.force_n = res.forces_n[-1]
        self.contraction_m = res.contractions_m[-1]
        self._publish(t_ns, res.stiffness_n_per_m, res.friction_n)
        self.samples_pub.publish(stamped(MuscleSamples, t_ns, self.joint, step=floats(steps),
                                         force=floats(res.forces_n),
                                         contraction=floats(res.contractions_m),
                                         record=samples.record))

    def _publish(self, t_ns: int, stiffness: float, friction: float) -> None:
        self.pub.publish(stamped(MuscleState, t_ns, self.joint, pressure=self.pressure_pa,
                                 force=self.force_n, contraction=self.contraction_m,
                                 volume=self.model.volume(self.contraction_m),
                                 stiffness=stiffness, friction_force=friction))


def main(args: list[str] | None = None) -> None:
    """Run the node."""
    run_node(MuscleSim, args)


if __name__ == '__main__':
    main()
