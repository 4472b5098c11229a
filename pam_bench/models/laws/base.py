"""What every static force law of the zoo is: F(theta, p, x, l0) with its fit start and bounds.

Notation shared by the laws: gauge pressure p (Pa; p_bar = p / 1e5 where a seed wrote its law
in bar), contraction x (m), contraction ratio k = x / l0 with the nominal length l0 (m), force
F (N). A law is vectorised: p and x are arrays of one shape, F has that shape.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

__all__ = ['ForceLaw', 'LawFunction']

LawFunction = Callable[[np.ndarray, np.ndarray, np.ndarray, float], np.ndarray]
"""law(theta, p Pa, x m, l0 m) -> F N."""


@dataclasses.dataclass(frozen=True)
class ForceLaw:
    """A static force law with its parameter names, fit start point and bounds.

    Attributes:
        name: the law's key in reports.
        seed: the seed and equation it comes from.
        params: parameter names, with their unit in the name.
        start, lower, upper: fit start and bounds, one per parameter.
        law: the function.
        min_x_m: the law is fitted and scored on readings with x >= this only (m).
        extends: (name of a law this one contains, the parameters at which this law equals
            that one given its fitted parameters): a fit also starts there, so it is never
            worse than the law it extends.
    """

    name: str
    seed: str
    params: tuple[str, ...]
    start: tuple[float, ...]
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    law: LawFunction
    min_x_m: float = -math.inf
    extends: tuple[str, Callable[[np.ndarray], tuple[float, ...]]] | None = None
