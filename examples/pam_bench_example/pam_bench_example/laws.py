"""A braided-pneumatic-actuator force law of the Hunt-Graber-Quinn kind, as a pam_bench plug-in.

After A. Hunt, A. Graber-Tilton and R. Quinn, "Modeling length effects of braided pneumatic
actuators", ASME IDETC 2017: the actuator's pressure as a function of its strain and force,
with a tangent that grows without bound as the strain nears a largest strain, which itself
falls as the load grows, and a term linear in the force:

    P(F, k) = a0 + a1 tan(a2 (k / (k_max + a4 F) + a3)) + a5 F

with gauge pressure P (Pa), strain (contraction ratio) k = x / l0, force F (N). pam_bench asks
for the force at a pressure and contraction, so the law is solved for F: P(F, k) grows with F
(a4 <= 0, a5 > 0), and F is found by bisection on [0, ``F_MAX_N``]; where even F = 0 needs
more pressure than p, the muscle is slack (F = 0). The defaults are illustrative values for a
muscle of 004's size (about 1500 N at 0.6 MPa and k = 0), not the paper's fitted ones.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from pam_bench.models.laws.base import ForceLaw
from pam_bench.vocabulary.params import field

__all__ = ['HuntGraberQuinnParams', 'force', 'LAW', 'F_MAX_N']

F_MAX_N = 1.0e4
"""Upper end of the bracket the force is solved in, N."""
BRACKET_N = 1.0
"""Bisection narrows the bracket to this width, N, before regula falsi takes over."""
TOLERANCE_N = 1.0e-9
"""The bracket's width where the solve ends, N."""
FALSI_STEPS = 50
"""Most regula falsi steps (it usually ends within five)."""


@dataclasses.dataclass
class HuntGraberQuinnParams:
    """The law's parameters (module docstring)."""

    a0_pa: float = field(2.0e4, 'Pa', 'pressure at zero force and strain', 0.0, 2.0e5)
    a1_pa: float = field(1.5e5, 'Pa', 'scale of the tangent term', 1.0e3, 1.0e6)
    a2: float = field(math.pi / 2, '-', 'argument scale of the tangent', 0.5, 3.0)
    a3: float = field(0.0, '-', 'argument offset of the tangent', -0.5, 0.5)
    a4_per_n: float = field(-1.0e-4, '1/N', 'fall of the largest strain per newton', -1.0e-3,
                            0.0)
    k_max: float = field(0.30, '-', 'largest strain at zero force', 0.05, 0.5)
    a5_pa_per_n: float = field(387.0, 'Pa/N', 'pressure per newton of force', 1.0, 1.0e4)


def _pressure(th: np.ndarray, f: float, k: float) -> float:
    """P(F, k) of the law (module docstring), Pa; the tangent's argument kept inside
    (-1.5, 1.5) rad and the largest strain above 1e-6."""
    a0, a1, a2, a3, a4, kmax, a5 = th[0], th[1], th[2], th[3], th[4], th[5], th[6]
    arg = a2 * (k / max(kmax + a4 * f, 1e-6) + a3)
    return a0 + a1 * math.tan(min(max(arg, -1.5), 1.5)) + a5 * f


def _force_at(th: np.ndarray, p: float, k: float) -> float:
    """The force at pressure p and strain k, N; 0 where even F = 0 needs more pressure than p
    (slack). P(F, k) = p is solved on [0, ``F_MAX_N``] by regula falsi with the Illinois
    step, to ``TOLERANCE_N``: P grows with F for k >= 0 (the root is unique). A stretched
    muscle (k < 0) can have more than one root: bisection (the half where P at the midpoint
    exceeds p is the upper one) first narrows the bracket to ``BRACKET_N``, which picks the
    root, then regula falsi ends inside it. A few evaluations of P instead of 44 halvings."""
    if _pressure(th, 0.0, k) >= p:
        return 0.0
    lo, hi = 0.0, F_MAX_N
    while k < 0.0 and hi - lo > BRACKET_N:
        mid = 0.5 * (lo + hi)
        if _pressure(th, mid, k) > p:
            hi = mid
        else:
            lo = mid
    g_lo, g_hi = _pressure(th, lo, k) - p, _pressure(th, hi, k) - p
    f = 0.5 * (lo + hi)
    if not (g_lo <= 0.0 < g_hi):            # no sign change left to follow: the midpoint
        return f
    side = 0
    for _ in range(FALSI_STEPS):
        f = (lo * g_hi - hi * g_lo) / (g_hi - g_lo)
        g = _pressure(th, f, k) - p
        if g > 0.0:
            hi, g_hi = f, g
            if side == -1:
                g_lo *= 0.5
            side = -1
        else:
            lo, g_lo = f, g
            if side == 1:
                g_hi *= 0.5
            side = 1
        if hi - lo <= TOLERANCE_N or g == 0.0:
            break
    return f


def force(th: np.ndarray, p: np.ndarray, x: np.ndarray, l0: float) -> np.ndarray:
    """F(p, x) of the law, N (module docstring); p in Pa and x in m, float arrays of one
    shape (n,); l0 in m. Plain loops and scalar arithmetic over arrays, so pam_bench
    compiles it (pam_bench's docs/plugins.md, 'What makes a law compile')."""
    out = np.zeros(p.shape)
    for i in range(p.shape[0]):
        out[i] = _force_at(th, p[i], x[i] / l0)
    return out


LAW = ForceLaw.from_settings('hunt_graber_quinn', 'Hunt, Graber-Tilton and Quinn 2017',
                             HuntGraberQuinnParams, force)
"""The entry point ``pam_bench.muscle_laws: hunt_graber_quinn``."""
