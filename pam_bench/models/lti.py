"""Exact discretisation of linear time-invariant dynamics under a zero-order hold.

For x' = A x + B u with u constant over a step h, the exact update is
x(t + h) = Ad x(t) + Bd u with [[Ad, Bd], [0, I]] = expm([[A, B], [0, 0]] h) (Van Loan).
No closed form in the eigenvalues is used, so every damping regime (under-, critically and
over-damped, b^2 = 4c exactly) is handled by the same stable computation.

Two states (the valve's pressure loop, the identified force model) take a cheaper exact path
than ``expm`` (``zoh`` on a 2x2 A, about 20 times faster; the valve's loop changes with the
chamber volume at every step of a servo run, so its ZOH cannot be cached). With tau = tr A,
N = A - (tau/2) I and, by Cayley-Hamilton, N^2 = delta2 I where delta2 = tau^2/4 - det A:

    exp(A h) = exp(tau h / 2) (C I + S N),   C = cosh(sqrt(delta2) h),
                                             S = sinh(sqrt(delta2) h) / sqrt(delta2),

with C and S evaluated as entire functions of z = delta2 h^2 (cos / sin for z < 0, their
Taylor series for |z| < 1e-3), so nothing is divided by sqrt(delta2) = sqrt(b^2 - 4c) / 2 and
the critically damped case is not special. The input part is Bd = A^-1 (Ad - I) B; a nearly
singular A (det A h^2 < 1e-6, e.g. a first-order loop written with two states, or the 1 ns
flush tick of a lock-step run) takes the exponential's series where ||A|| h <= 0.1 and falls
back to ``expm`` beyond.
"""

from __future__ import annotations

import math

import numpy as np

from pam_bench.models import jit
from pam_bench.models.jit import Array

__all__ = ['zoh', 'zoh_2x2_floats', 'second_order_matrices', 'ZohCache', 'zoh_run']


def zoh(a: np.ndarray, b: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact ZOH discretisation.

    Args:
        a: state matrix, shape (n, n).
        b: input matrix, shape (n, m).
        h: step, s (>= 0).

    Returns:
        (Ad, Bd) with shapes (n, n) and (n, m).
    """
    a = np.atleast_2d(np.asarray(a, dtype=float))
    b = np.asarray(b, dtype=float).reshape(a.shape[0], -1)
    n, m = b.shape
    if n == 2:
        fast = _zoh_2x2(a, b, h)
        if fast is not None:
            return fast
    from scipy.linalg import expm  # here: its import is a third of a device node's start-up
    blk = np.zeros((n + m, n + m))
    blk[:n, :n] = a
    blk[:n, n:] = b
    e = expm(blk * h)
    return e[:n, :n], e[:n, n:]


def _scaled_cosh_sinhc(z: float, h: float, e: float) -> tuple[float, float, float]:
    """(exp(e) cosh(sqrt(z)) - 1, exp(e) h sinh(sqrt(z)) / sqrt(z)) and the first plus one,
    for real z = delta2 h^2 of any sign: no division by sqrt(z) near 0 (Taylor series to z^3,
    error below 1e-16 for |z| < 1e-3), no cancellation in the ``- 1`` for short steps
    (expm1, half-angle forms) and no overflow of cosh where exp(e) is small (a stiff loop)."""
    if abs(z) < 1e-3:
        cm1 = z / 2.0 * (1.0 + z / 12.0 * (1.0 + z / 30.0))         # cosh - 1
        sc = h * (1.0 + z / 6.0 * (1.0 + z / 20.0 * (1.0 + z / 42.0)))
    elif z < 0.0:
        r = math.sqrt(-z)
        cm1 = -2.0 * math.sin(0.5 * r) ** 2
        sc = h * math.sin(r) / r
    else:
        r = math.sqrt(z)
        if r > 1.0:
            up, down = math.exp(e + r), math.exp(e - r)
            gc = 0.5 * (up + down)
            return gc - 1.0, 0.5 * h * (up - down) / r, gc
        cm1 = 2.0 * math.sinh(0.5 * r) ** 2
        sc = h * math.sinh(r) / r
    em1 = math.expm1(e)
    gcm1 = em1 * (1.0 + cm1) + cm1                                     # exp(e) cosh - 1
    return gcm1, (1.0 + em1) * sc, 1.0 + gcm1


EXP_MAX = 709.78
"""Largest argument of exp taken (exp(709.78) is near a double's largest, 1.8e308)."""


def zoh_2x2_floats(a00: float, a01: float, a10: float, a11: float, b0: float, b1: float,
                   h: float) -> tuple[float, float, float, float, float, float] | None:
    """The closed form of the module docstring for x' = A x + B u with a 2x2 A and one input,
    in floats: (Ad00, Ad01, Ad10, Ad11, Bd0, Bd1) over the step ``h`` (s). None when A is
    nearly singular over the step or the step overflows (``zoh`` then uses ``expm``)."""
    det = a00 * a11 - a01 * a10
    if not (abs(det) * h * h >= 1e-6 and math.isfinite(det)):
        return _series_2x2(a00, a01, a10, a11, b0, b1, h)
    half = 0.5 * (a00 + a11)
    z = (half * half - det) * h * h
    if half * h + (math.sqrt(z) if z > 0.0 else 0.0) > EXP_MAX:   # exp would overflow (a
        return None                               # None, not a raise: compiled it gives inf)
    cm1, sh, c = _scaled_cosh_sinhc(z, h, half * h)
    # Ad - I = (c - 1) I + sh N, N = A - half I
    d00, d01 = cm1 + sh * (a00 - half), sh * a01
    d10, d11 = sh * a10, cm1 + sh * (a11 - half)
    if not (math.isfinite(d00) and math.isfinite(d01) and math.isfinite(d10)
            and math.isfinite(d11)):
        return None
    v0, v1 = d00 * b0 + d01 * b1, d10 * b0 + d11 * b1     # Bd = A^-1 (Ad - I) B
    return (1.0 + d00, d01, d10, 1.0 + d11, (a11 * v0 - a01 * v1) / det,
            (a00 * v1 - a10 * v0) / det)


SERIES_MAX_NORM_H = 0.1
"""Largest ||A||_inf h for which ``_series_2x2`` sums the exponential's series: 13 terms
leave a remainder below 0.1^13 / 13! = 2e-23, under a double's last bit."""


def _series_2x2(a00: float, a01: float, a10: float, a11: float, b0: float, b1: float,
                h: float) -> tuple[float, float, float, float, float, float] | None:
    """The ZOH of a 2x2 system over a step short against its dynamics (``||A|| h <= 0.1``:
    the lock-step's 1 ns flush tick, a nearly singular A over a short step) as the series
    Ad = sum (A h)^k / k!, Bd = h sum (A h)^k / (k + 1)! B, to 13 terms, in floats (no LAPACK
    call: its buffer allocation spins for ever when memory runs out). None when the step is
    not short enough (``zoh`` then uses ``expm``)."""
    norm = max(abs(a00) + abs(a01), abs(a10) + abs(a11)) * h
    if not (math.isfinite(norm) and norm <= SERIES_MAX_NORM_H):
        return None
    m00, m01, m10, m11 = a00 * h, a01 * h, a10 * h, a11 * h
    t00, t01, t10, t11 = 1.0, 0.0, 0.0, 1.0            # (A h)^k / k!
    e00, e01, e10, e11 = 1.0, 0.0, 0.0, 1.0            # sum of those
    f00, f01, f10, f11 = 1.0, 0.0, 0.0, 1.0            # sum of (A h)^k / (k + 1)!
    for k in range(1, 13):
        t00, t01, t10, t11 = ((t00 * m00 + t01 * m10) / k, (t00 * m01 + t01 * m11) / k,
                              (t10 * m00 + t11 * m10) / k, (t10 * m01 + t11 * m11) / k)
        e00, e01, e10, e11 = e00 + t00, e01 + t01, e10 + t10, e11 + t11
        f00, f01 = f00 + t00 / (k + 1), f01 + t01 / (k + 1)
        f10, f11 = f10 + t10 / (k + 1), f11 + t11 / (k + 1)
    return (e00, e01, e10, e11, h * (f00 * b0 + f01 * b1), h * (f10 * b0 + f11 * b1))


def _zoh_2x2(a: np.ndarray, b: np.ndarray, h: float
             ) -> tuple[np.ndarray, np.ndarray] | None:
    """``zoh_2x2_floats`` for each column of ``b``, as arrays (numpy's per-call cost would eat
    the gain inside); None as there."""
    a00, a01, a10, a11 = float(a[0, 0]), float(a[0, 1]), float(a[1, 0]), float(a[1, 1])
    bd = np.empty((2, b.shape[1]))
    ad = None
    for j in range(b.shape[1]):
        r = zoh_2x2_floats(a00, a01, a10, a11, float(b[0, j]), float(b[1, j]), h)
        if r is None:
            return None
        ad = r[:4]
        bd[0, j], bd[1, j] = r[4], r[5]
    if ad is None:                                     # no input column: Ad alone
        r = zoh_2x2_floats(a00, a01, a10, a11, 0.0, 0.0, h)
        if r is None:
            return None
        ad = r[:4]
    return np.array([[ad[0], ad[1]], [ad[2], ad[3]]]), bd


def second_order_matrices(b: float, c: float, d: float) -> tuple[np.ndarray, np.ndarray]:
    """State-space form of y'' + b y' + c y = d u with state (y, y').

    Returns:
        (A, B), shapes (2, 2) and (2, 1).
    """
    return np.array([[0.0, 1.0], [-c, -b]]), np.array([[0.0], [d]])


class ZohCache:
    """Memoises ``zoh`` for a few (key, h) pairs: the hot path reuses one step size."""

    def __init__(self, size: int = 8) -> None:
        self._size = size
        self._store: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
        self._floats: dict[tuple, tuple[float, float, float, float, float, float]] = {}

    def get(self, key: tuple, a: np.ndarray, b: np.ndarray, h: float
            ) -> tuple[np.ndarray, np.ndarray]:
        """(Ad, Bd) for the system named ``key`` over step ``h``. A 2x2 system with one input
        goes through ``get_2x2``: one store for both, so that a caller of either finds what the
        other computed."""
        if a.shape == (2, 2) and b.shape == (2, 1):
            f = self.get_2x2(key, float(a[0, 0]), float(a[0, 1]), float(a[1, 0]),
                             float(a[1, 1]), float(b[0, 0]), float(b[1, 0]), h)
            return np.array([[f[0], f[1]], [f[2], f[3]]]), np.array([[f[4]], [f[5]]])
        k = (key, h)
        hit = self._store.get(k)
        if hit is None:
            if len(self._store) >= self._size:
                self._store.pop(next(iter(self._store)))
            hit = zoh(a, b, h)
            self._store[k] = hit
        return hit

    def get_2x2(self, key: tuple, a00: float, a01: float, a10: float, a11: float, b0: float,
                b1: float, h: float) -> tuple[float, float, float, float, float, float]:
        """(Ad00, Ad01, Ad10, Ad11, Bd0, Bd1) for the 2x2 system named ``key`` with one input
        over step ``h``: ``get`` in floats, without building the arrays where the closed form
        applies (the valve of a servo run misses the cache at every exchange)."""
        k = (key, h, 1)
        hit = self._floats.get(k)
        if hit is None:
            hit = zoh_2x2_floats(a00, a01, a10, a11, b0, b1, h)
            if hit is None:
                ad, bd = zoh(np.array([[a00, a01], [a10, a11]]), np.array([[b0], [b1]]), h)
                hit = (float(ad[0, 0]), float(ad[0, 1]), float(ad[1, 0]), float(ad[1, 1]),
                       float(bd[0, 0]), float(bd[1, 0]))
            if len(self._floats) >= self._size:
                self._floats.pop(next(iter(self._floats)))
            self._floats[k] = hit
        return hit


# --- compiled (models.jit) ------------------------------------------------------------------
def _zoh_run(s0: float, s1: float, a00: float, a01: float, a10: float, a11: float, b0: float,
             b1: float, n: int, p_max: float, out: Array, start: int) -> tuple[float, float]:
    """``n`` equal ZOH sub-steps from the state (s0 Pa, s1 Pa/s) with the (already scaled)
    input terms b0, b1; the clamped gauge pressure of each into ``out[start:start + n]``.
    Returns the state after them."""
    for i in range(n):
        s0, s1 = a00 * s0 + a01 * s1 + b0, a10 * s0 + a11 * s1 + b1
        out[start + i] = min(max(s0, 0.0), p_max)
    return s0, s1


zoh_run = jit.kernel('zoh_run', _zoh_run, lambda: (
    0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 2, 1.0, np.zeros(2), 0))
