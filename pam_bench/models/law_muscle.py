"""A force law of the zoo (or a lab's plug-in law) as the bench's muscle.

The law gives the friction-free backbone, F_bb(p, x) = law(theta, p, x, l_n) (N; gauge
pressure p Pa, contraction x m, nominal length l_n m, ``models.laws.base``), and the bench
adds what every bench muscle shares (``models.muscle.FrictionMuscle``): the braid's
Maxwell-slip friction on s = x + c_t F_bb^+ (004 section 2.2, ``models.friction``) and the
clamp F >= 0 (a muscle never pushes). The stiffness -dF_bb/dx is the law's central
difference over +-``DX_M``. The law runs compiled by numba when it compiles and gives its
own forces (``laws.base.law_function``), else as written (``interpreted_why`` says why);
``muscle.law_core`` may ask for it as written (``law_core_for``: a scene of short exchanges,
where numba's start-up costs more than the law's calls save). The
chamber volume is the McKibben braid's (001 Eq. 1-2,
``MuscleModel.volume``) from the muscle's geometry, which the valve's loop asks for. The
friction parameters and the geometry are the muscle's (``muscle.*``), the law's parameters
its own (``laws.LAW.*``).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from pam_bench.models.errors import ModelError
from pam_bench.models.friction import MaxwellSlip
from pam_bench.models.laws.base import ForceLaw, law_function
from pam_bench.models.muscle import FrictionMuscle, MuscleModel, MuscleParams

__all__ = ['LawMuscle', 'DX_M', 'law_core_for', 'with_law_core']

DX_M = 1.0e-6
"""Half-step of the central difference of the stiffness, m."""


def law_core_for(exchange_step_s: float, sub_step_s: float) -> str:
    """How a scene's force law runs, decided before the run from the scene alone: 'compiled'
    when one exchange holds ``jit.LOAD_AT`` sub-steps or more, else 'interpreted'.

    The rule is the one by which the built-in muscle loads its compiled core
    (``models.jit.wanted``): below it every exchange runs the interpreted loop, and numba's
    import and the law's load from its cache (about 0.6 s) cost more than the compiled law's
    calls save (the demo, 2 sub-steps an exchange: 1.75 s interpreted against 2.19 s compiled;
    BENCHMARKS.md). The built-in muscle switches when its kernels have loaded, bit-equal; a
    compiled law agrees with itself interpreted to ``laws.base.CHECK_RTOL`` only, so the
    choice is made once, before the run, and every engine (nodes, twin) reads it from the
    scene's settings: the same scene gives the same bag.
    """
    from pam_bench.models import jit
    return 'compiled' if exchange_step_s >= jit.LOAD_AT * sub_step_s else 'interpreted'


def with_law_core(muscle: MuscleParams, exchange_step_s: float,
                  sub_step_s: float) -> MuscleParams:
    """``muscle`` with a force law left to 'auto' decided for these steps (``law_core_for``);
    any other muscle as it is. The scene's settings and the twin's protocol run both call it."""
    if muscle.kind != 'law' or muscle.law_core != 'auto':
        return muscle
    return dataclasses.replace(muscle, law_core=law_core_for(exchange_step_s, sub_step_s))


class LawMuscle(FrictionMuscle):
    """The law ``law`` with its parameters ``values`` (a settings object of ``law.settings``)
    on the bench (module docstring)."""

    def __init__(self, law: ForceLaw, values: Any, params: MuscleParams | None = None) -> None:
        self.p = params or MuscleParams()
        self.law = law
        self.theta = law.theta(values)
        if not np.all(np.isfinite(self.theta)):
            raise ModelError(f'force law {law.name}: parameters not finite: {self.theta}')
        self._geometry = MuscleModel(self.p)
        self.friction = MaxwellSlip(self.p.friction_stiffness_n_per_m,
                                    self.p.friction_break_force_n,
                                    self.p.friction_break_force_ratio)
        self._l0 = self.p.nominal_length_m
        self._offsets = np.array([0.0, -DX_M, DX_M])
        if self.p.law_core == 'interpreted':
            self._law, self.interpreted_why = law.law, 'muscle.law_core is interpreted'
        else:
            self._law, self.interpreted_why = law_function(law)

    def backbone_and_stiffness(self, pressure_pa: float, contraction_m: float
                               ) -> tuple[float, float]:
        """(F_bb N, -dF_bb/dx N/m) of the law (module docstring): the law evaluated once at
        x and x -+ ``DX_M``."""
        x = contraction_m + self._offsets
        f = self._law(self.theta, np.full(3, pressure_pa), x, self._l0)
        f0, fm, fp = float(f[0]), float(f[1]), float(f[2])
        if not (math.isfinite(f0) and math.isfinite(fm) and math.isfinite(fp)):
            raise ModelError(f'force law {self.law.name} gives {f0!r} at p = {pressure_pa!r} '
                             f'Pa, x = {contraction_m!r} m')
        return f0, -(fp - fm) / (2.0 * DX_M)

    def reset(self, contraction_m: float = 0.0, pressure_pa: float = 0.0) -> None:
        """Friction relaxed at the given state."""
        tension = max(self.backbone(pressure_pa, contraction_m), 0.0)
        self.friction.reset(contraction_m + self.p.slip_compliance_m_per_n * tension)

    def arrays(self) -> tuple[Any, ...]:
        """The muscle as its compiled solve takes it (``law_kernel``): (theta, l0 m,
        hysteresis 0/1, c_t m/N), then the friction elements' stiffness, break force, growth,
        positions and sticking flags, shapes (n,)."""
        fr = self.friction
        return ((self.theta, float(self._l0), 1.0 if self.p.hysteresis else 0.0,
                 float(self.p.slip_compliance_m_per_n)), np.array(fr.k), np.array(fr.f0),
                np.array(fr.mu), np.array(fr.z), np.array(fr.sticking, dtype=np.uint8))

    def kernel(self) -> Any:
        """The compiled solve of this law's exchanges (``models.law_kernel``), or None: the
        interpreted loop runs them (as it does for a law asked to run interpreted)."""
        if self.p.law_core == 'interpreted':
            return None
        from pam_bench.models.law_kernel import law_kernel
        return law_kernel(self.law, DX_M)[0]

    def volume(self, contraction_m: float) -> float:
        """The McKibben braid's chamber volume at x, m^3."""
        return self._geometry.volume(contraction_m)
