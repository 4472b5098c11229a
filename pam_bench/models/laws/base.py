"""What every static force law of the zoo is: F(theta, p, x, l0) with its fit start and bounds.

Notation shared by the laws: gauge pressure p (Pa; p_bar = p / 1e5 where a seed wrote its law
in bar), contraction x (m), contraction ratio k = x / l0 with the nominal length l0 (m), force
F (N). A law is vectorised: p and x are arrays of one shape, F has that shape.

A law's parameters are a settings class (``vocabulary.params.field``: default, unit, range,
text; ``ForceLaw.settings``): a lab's plug-in law declares its own
(``ForceLaw.from_settings``), the zoo's laws have one made from their names, starts and
bounds. The bench addresses them by path, ``muscle_N.laws.LAW.PARAMETER``
(``config.settings.LawSettings``), and holds the law a scene names (``muscle.kind: law``,
``muscle.law: LAW``, ``models.law_muscle``).
"""

from __future__ import annotations

import dataclasses
import math
import sys
from collections.abc import Callable
from typing import Any

import numpy as np

from pam_bench.vocabulary.params import field, param_infos

__all__ = ['ForceLaw', 'LawFunction', 'law_function', 'CHECK_RTOL']

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
    settings_class: type | None = None

    @classmethod
    def from_settings(cls, name: str, seed: str, settings: type, law: LawFunction,
                      min_x_m: float = -math.inf) -> ForceLaw:
        """A law whose parameters are the leaves of the settings dataclass ``settings``, in
        order: each field's default is the fit's start, its range the fit's bounds (a plug-in
        law declares itself so)."""
        infos = param_infos(settings)
        return cls(name, seed, tuple(i.name for i in infos),
                   tuple(float(i.default) for i in infos),
                   tuple(-math.inf if i.low is None else float(i.low) for i in infos),
                   tuple(math.inf if i.high is None else float(i.high) for i in infos),
                   law, min_x_m, None, settings)

    @property
    def settings(self) -> type:
        """The law's parameters as a settings dataclass (made from the names, starts and
        bounds for a law declared without one)."""
        if self.settings_class is not None:
            return self.settings_class
        return _made_settings(self)

    def theta(self, values: Any) -> np.ndarray:
        """The parameter vector of a settings object of this law, in ``params`` order."""
        return np.array([float(getattr(values, n)) for n in self.params])


_MADE: dict[str, type] = {}
_UNITS = (('_N_per_Pa_m', 'N/(Pa m)'), ('_N_per_Pa', 'N/Pa'), ('_N_per_m', 'N/m'),
          ('_Pa', 'Pa'), ('_rad', 'rad'), ('_m', 'm'), ('_N', 'N'))
"""A parameter's unit from its name's ending (the zoo names them so)."""


def _made_settings(law: ForceLaw) -> type:
    """A settings dataclass for a law declared by names, starts and bounds; registered in this
    module (so its objects pickle) under ``<Name>LawParams``."""
    cls = _MADE.get(law.name)
    if cls is not None:
        return cls
    fields = []
    for n, start, lo, hi in zip(law.params, law.start, law.lower, law.upper, strict=True):
        unit = next((u for suffix, u in _UNITS if n.endswith(suffix)), '-')
        fields.append((n, float, field(float(start), unit,
                                       f'{law.name} parameter {n} ({law.seed})',
                                       None if math.isinf(lo) else float(lo),
                                       None if math.isinf(hi) else float(hi))))
    qual = ''.join(part.capitalize() for part in law.name.split('_')) + 'LawParams'
    cls = dataclasses.make_dataclass(qual, fields)
    cls.__module__ = __name__
    cls.__doc__ = f'Parameters of the force law {law.name} ({law.seed}).'
    setattr(sys.modules[__name__], qual, cls)
    _MADE[law.name] = cls
    return cls


CHECK_RTOL = 1.0e-9
"""A compiled law must give the interpreted one's forces within this share (and 1e-9 N)."""


def law_function(law: ForceLaw) -> tuple[LawFunction, str]:
    """The function the bench evaluates ``law`` with, and '' or why it runs interpreted.

    A law written in numpy arithmetic over arrays (``docs/plugins.md``, 'What makes a law
    compile') is compiled by numba (``models.jit.compile_function``) and checked against
    itself interpreted on a grid of pressures (0 to 0.6 MPa) and contractions (-1 to 30 % of
    l0) at its start parameters: its forces must agree within ``CHECK_RTOL``. A law numba
    cannot type, or whose compiled forces differ, runs as written.
    """
    from pam_bench.models import jit
    theta = np.array(law.start, dtype=float)
    l0 = 0.35
    p = np.repeat(np.array([0.0, 1.0e5, 3.0e5, 6.0e5]), 4)
    x = np.tile(np.array([-0.01, 0.0, 0.1, 0.3]) * l0, 4)
    fast, why = jit.compile_function(law.law, (theta, p.copy(), x.copy(), l0))
    if fast is None:
        return law.law, why
    try:
        want = np.asarray(law.law(theta, p.copy(), x.copy(), l0), dtype=float)
        got = np.asarray(fast(theta, p.copy(), x.copy(), l0), dtype=float)
    except Exception as exc:  # noqa: BLE001 - the law's own failure: it runs as written
        return law.law, f'its check failed: {type(exc).__name__}: {exc}'[:300]
    if want.shape != got.shape or not np.allclose(got, want, rtol=CHECK_RTOL, atol=1e-9,
                                                  equal_nan=True):
        return law.law, 'compiled, it gives other forces than as written (not used)'
    return fast, ''
