"""A braided-pneumatic-actuator force law of the Hunt-Graber-Quinn kind, as a pam_bench plug-in.

After A. Hunt, A. Graber-Tilton and R. Quinn, "Modeling length effects of braided pneumatic
actuators", ASME IDETC 2017: the actuator's pressure as a function of its strain and force,
with a tangent that grows without bound as the strain nears a largest strain, which itself
falls as the load grows, and a term linear in the force:

    P(F, k) = a0 + a1 tan(a2 (k / (k_max + a4 F) + a3)) + a5 F

with gauge pressure P (Pa), strain (contraction ratio) k = x / l0, force F (N). pam_bench asks
for the force at a pressure and contraction, so the law is solved for F in [0, ``F_MAX_N``];
where even F = 0 needs more pressure than p, the muscle is slack (F = 0). For k >= 0, P(F, k)
grows with F (a4 <= 0, a5 > 0) and the root is unique. A stretched muscle (k < 0) is outside
the paper's range: there P first rises with F, then falls as the largest strain shrinks towards
|k|, then, with the tangent held at its limit, rises again as a5 F, so P = p can have three
roots. The force is the smallest, on the branch that rises from F = 0 (a stretched muscle at
p = 0 pulls a few tens of newtons, not the kilonewtons of the far root), and where that branch
peaks below p, the force at its peak; so the force is continuous in p and x. A stretched
muscle also pulls with its braid locked, as the bench's own muscle does (004's lock-up
stiffness k_s, N/m): the force is F(p, x) = F_P(p, x / l0) + k_s max(-x, 0), with F_P the
solve above and x = k l0 the contraction (m), so the load the isotonic protocol hangs on a
vented muscle stretches it by millimetres. The defaults are illustrative values for a muscle of
004's size (about 1500 N at 0.6 MPa and k = 0), not the paper's fitted ones.
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
NEWTON_STEPS = 60
"""Most Newton steps for a stretched muscle's force (it usually ends within eight)."""
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
    stretch_stiffness_n_per_m: float = field(1.082e5, 'N/m', 'braid lock-up stiffness k_s '
                                             'when stretched (x < 0), as in 004', 1.0e3, 1.0e7)


def _pressure(th: np.ndarray, f: float, k: float) -> float:
    """P(F, k) of the law (module docstring), Pa; the tangent's argument kept inside
    (-1.5, 1.5) rad and the largest strain above 1e-6."""
    a0, a1, a2, a3, a4, kmax, a5 = th[0], th[1], th[2], th[3], th[4], th[5], th[6]
    arg = a2 * (k / max(kmax + a4 * f, 1e-6) + a3)
    return a0 + a1 * math.tan(min(max(arg, -1.5), 1.5)) + a5 * f


def _slope(th: np.ndarray, f: float, k: float) -> float:
    """dP/dF of ``_pressure`` at (f, k), Pa/N: a5 where the tangent's argument or the largest
    strain is held past its limit, else a5 + a1 sec^2(arg) a2 (-k a4) / (k_max + a4 F)^2 (at
    the limit itself, the slope from inside)."""
    a1, a2, a3, a4, kmax, a5 = th[1], th[2], th[3], th[4], th[5], th[6]
    den = kmax + a4 * f
    if den < 1e-6 * (1.0 - 1e-9):
        return a5
    arg = a2 * (k / den + a3)
    if arg < -1.5 - 1e-9 or arg > 1.5 + 1e-9:
        return a5
    t = math.tan(arg)
    return a5 + a1 * (1.0 + t * t) * a2 * (-k * a4) / (den * den)


def _branch_end(th: np.ndarray, k: float) -> float:
    """For a stretched muscle (k < 0): the force where the tangent's argument falls to -1.5 rad
    or the largest strain to 1e-6, whichever comes first, N (at most ``F_MAX_N``, at least 0).
    Past it the tangent is held and P(F) is a line of slope a5 that meets p again at forces
    of kilonewtons (module docstring), which no stretched muscle of the law's range reaches."""
    a2, a3, a4, kmax = th[2], th[3], th[4], th[5]
    if a4 >= 0.0:
        return F_MAX_N
    end = min((1e-6 - kmax) / a4, F_MAX_N)
    q = -1.5 / a2 - a3                      # k / (k_max + a4 F) where the argument is -1.5
    if q >= 0.0:
        return 0.0
    end = min(end, (k / q - kmax) / a4)
    return max(end, 0.0)


def _falsi(th: np.ndarray, p: float, k: float, lo: float, hi: float, g_lo: float,
           g_hi: float) -> float:
    """A root of P(F, k) = p in [lo, hi], where P(lo) - p = g_lo <= 0 < g_hi = P(hi) - p, N:
    regula falsi with the Illinois step, to ``TOLERANCE_N`` or ``FALSI_STEPS`` steps."""
    f = 0.5 * (lo + hi)
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


def _peak(th: np.ndarray, k: float, lo: float, hi: float) -> float:
    """The force of P's largest value in [lo, hi], N, where P rises at lo and not at hi:
    bisection on the sign of dP/dF to ``TOLERANCE_N``."""
    while hi - lo > TOLERANCE_N:
        mid = 0.5 * (lo + hi)
        if _slope(th, mid, k) > 0.0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def _stretched(th: np.ndarray, p: float, k: float) -> float:
    """The force of a stretched muscle (k < 0) at pressure p, N, where P(0, k) < p: the
    smallest root of P(F, k) = p on [0, ``_branch_end``], the branch that rises from F = 0.
    Newton's method from F = 0 stays left of that root where P is concave (the law's own
    parameters), so it finds the smallest root; a step that passes a root hands the bracket to
    regula falsi. Where the branch peaks below p (a stretch far past the law's range), the
    force at its peak, so the force stays continuous in p and x."""
    end = _branch_end(th, k)
    lo, before = 0.0, 0.0
    for _ in range(NEWTON_STEPS):
        g = _pressure(th, lo, k) - p
        d = _slope(th, lo, k)
        if d <= 0.0:
            return _peak(th, k, before, lo)
        f = min(lo - g / d, end)
        g_f = _pressure(th, f, k) - p
        if g_f > 0.0:
            return _falsi(th, p, k, lo, f, g, g_f)
        if f >= end:
            return end if _slope(th, end, k) > 0.0 else _peak(th, k, lo, end)
        if f - lo <= TOLERANCE_N:
            return f
        before, lo = lo, f
    return lo


def _force_at(th: np.ndarray, p: float, k: float) -> float:
    """The force at pressure p and strain k, N; 0 where even F = 0 needs more pressure than p
    (slack). For k >= 0, P grows with F and the root of P(F, k) = p on [0, ``F_MAX_N``] is
    unique: regula falsi finds it. A stretched muscle (k < 0) has the force of
    ``_stretched``."""
    g_0 = _pressure(th, 0.0, k) - p
    if g_0 >= 0.0:
        return 0.0
    if k < 0.0:
        return _stretched(th, p, k)
    g_max = _pressure(th, F_MAX_N, k) - p
    if g_max <= 0.0:
        return F_MAX_N
    return _falsi(th, p, k, 0.0, F_MAX_N, g_0, g_max)


def force(th: np.ndarray, p: np.ndarray, x: np.ndarray, l0: float) -> np.ndarray:
    """F(p, x) of the law, N (module docstring); p in Pa and x in m, float arrays of one
    shape (n,); l0 in m. Plain loops and scalar arithmetic over arrays, so pam_bench
    compiles it (pam_bench's docs/plugins.md, 'What makes a law compile')."""
    out = np.zeros(p.shape)
    for i in range(p.shape[0]):
        out[i] = _force_at(th, p[i], x[i] / l0)
        if x[i] < 0.0:
            out[i] -= th[7] * x[i]
    return out


LAW = ForceLaw.from_settings('hunt_graber_quinn', 'Hunt, Graber-Tilton and Quinn 2017',
                             HuntGraberQuinnParams, force)
"""The entry point ``pam_bench.muscle_laws: hunt_graber_quinn``."""
