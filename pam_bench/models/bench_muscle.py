"""Which muscle the bench holds: ``muscle.kind`` picks the law, the rest of the bench does not
care (the valve asks a volume, the coupled solve asks force and stiffness).

- ``mckibben``: 004's muscle, ``pam_bench.models.muscle`` (parameters ``muscle.*``);
- ``straight_fibre``: 000's muscle, ``pam_bench.models.straight_fibre_muscle`` (parameters
  ``straight_fibre.*``);
- ``law``: a force law of the zoo or a plug-in (``muscle.law``), ``pam_bench.models.law_muscle``
  (its parameters ``laws.LAW.*``, the friction and geometry ``muscle.*``).
"""

from __future__ import annotations

from typing import Any, Protocol

from pam_bench.models.muscle import MuscleModel, MuscleOutput, MuscleParams, MuscleTrial
from pam_bench.models.straight_fibre_muscle import StraightFibreMuscle, StraightFibreParams
from pam_bench.vocabulary.errors import ParameterError
from pam_bench.vocabulary.params import hint

__all__ = ['KINDS', 'BenchMuscle', 'make_muscle']

KINDS = ('mckibben', 'straight_fibre', 'law')


class BenchMuscle(Protocol):
    """What the bench asks of a muscle (SI units; see ``MuscleModel``)."""

    def reset(self, contraction_m: float = 0.0, pressure_pa: float = 0.0) -> None:
        """Friction relaxed at (x m, p Pa)."""

    def trial(self, pressure_pa: float, contraction_m: float) -> MuscleTrial:
        """(F N, -dF/dx N/m, friction N, friction trial) at (p, x), not kept."""

    def commit(self, trial: MuscleTrial) -> None:
        """Keep the friction state of a trial."""

    def step(self, pressure_pa: float, contraction_m: float) -> MuscleOutput:
        """Move to (p, x) and return the output."""

    def volume(self, contraction_m: float) -> float:
        """Chamber volume at x, m^3."""

    def static_force(self, pressure_pa: float, contraction_m: float) -> float:
        """Friction-free force, N."""


def make_muscle(muscle: MuscleParams | None = None,
                straight_fibre: StraightFibreParams | None = None,
                laws: Any = None) -> BenchMuscle:
    """The muscle ``muscle.kind`` names, built from its parameter set (``laws``: the
    parameters of every force law, ``config.settings.LawSettings``; None: each law's
    defaults).

    Raises:
        ParameterError: an unknown kind or law (names the nearest), or a bad parameter set.
    """
    muscle = muscle or MuscleParams()
    if muscle.kind == 'mckibben':
        return MuscleModel(muscle)
    if muscle.kind == 'straight_fibre':
        return StraightFibreMuscle(straight_fibre)
    if muscle.kind == 'law':
        from pam_bench.models.law_muscle import LawMuscle
        from pam_bench.models.laws.zoo import force_law
        law = force_law(muscle.law)
        values = getattr(laws, law.name, None) if laws is not None else None
        return LawMuscle(law, values if values is not None else law.settings(), muscle)
    raise ParameterError(f'muscle.kind: unknown muscle {muscle.kind!r} '
                         f'({hint(muscle.kind, KINDS)})')
