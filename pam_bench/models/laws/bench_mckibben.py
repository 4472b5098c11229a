"""The bench's own McKibben law (``pam_bench.models.muscle``), friction-free, as a force law
the extraction can fit like the seeds' laws.

F = g(x) e(p) - k_bl x, N, with the gain g(x) = g_m + (g0 - g_m) (1 - x / x_m)^n below x_m and
g_m + g_r (x - x_m) past it (N/Pa), the effective pressure
e(p) = w [S((p - p_th) / w) - S(-p_th / w)], S(z) = ln(1 + e^z) (Pa), and the bladder's
elasticity k_bl (N/m); muscle.py derives the law and cites 004 for its figures.
``MuscleModel`` evaluates the same law, plus the braid's lock-up for x < 0, its lock at the
largest contraction and the friction; a test holds the two equal.
"""

from __future__ import annotations

import numpy as np

from pam_bench.models.laws.base import ForceLaw

__all__ = ['force', 'LAW']


def _softplus(z: np.ndarray) -> np.ndarray:
    return np.maximum(z, 0.0) + np.log1p(np.exp(-np.abs(z)))


def force(th: np.ndarray, p: np.ndarray, x: np.ndarray, l0: float) -> np.ndarray:
    """The backbone with th = (g0 N/Pa, g_m N/Pa, x_m m, n, g_r N/(Pa m), p_th Pa, w Pa,
    k_bl N/m), N (l0 unused)."""
    g0, gm, xm, n, gr, pth, w, kbl = th
    r = np.maximum(1.0 - x / xm, 0.0)
    g = np.where(x <= xm, gm + (g0 - gm) * r ** n, gm + gr * (x - xm))
    pp = np.maximum(p, 0.0)
    if w > 0.0:
        e = np.maximum(w * (_softplus((pp - pth) / w) - _softplus(np.asarray(-pth / w))), 0.0)
    else:
        e = np.maximum(pp - pth, 0.0)
    return g * e - kbl * x


LAW = ForceLaw('bench_mckibben', '004 (muscle.py)',
               ('g0_N_per_Pa', 'g_m_N_per_Pa', 'x_m_m', 'n', 'g_r_N_per_Pa_m', 'p_th_Pa', 'w_Pa',
                'k_bl_N_per_m'),
               (2.8e-3, 1.0e-4, 0.12, 2.5, 0.0, 1.0e4, 1.0e4, 100.0),
               (1e-5, 0.0, 0.02, 1.0, 0.0, 0.0, 0.0, 0.0),
               (0.1, 1e-2, 2.0, 10.0, 1e-2, 2.0e5, 2.0e5, 1.0e5), force)
