"""The bench's own McKibben law (``pam_bench.models.muscle``), friction-free, as a force law
the extraction can fit like the seeds' laws.

F = g0 (1 - x / x_z)^n (p - p_th)^+ - k_bl x  (x < x_z; the gain term is 0 beyond), N: g0 the
isometric gain at x = 0 (N/Pa), x_z the contraction where the gain reaches 0 (m), n its
exponent (-), p_th the threshold pressure (Pa), k_bl the bladder's elasticity (N/m). The gain
curve plays the role of pi r0^2 [a (1 - k)^2 - b] in 001 Eq. 3 / 002 Eq. 2 with a free
exponent (muscle.py derives it and cites 004 for its two isometric gains). ``MuscleModel``
evaluates the same law, plus the braid lock-up for x < 0 and the friction, unrolled for speed;
a test holds the two equal.
"""

from __future__ import annotations

import numpy as np

from pam_bench.models.laws.base import ForceLaw

__all__ = ['force', 'LAW']


def force(th: np.ndarray, p: np.ndarray, x: np.ndarray, l0: float) -> np.ndarray:
    """The backbone with th = (g0 N/Pa, x_z m, n, p_th Pa, k_bl N/m), N (l0 unused)."""
    g0, xz, n, pth, kbl = th
    r = np.maximum(1.0 - x / xz, 0.0)
    return g0 * r ** n * np.maximum(p - pth, 0.0) - kbl * x


LAW = ForceLaw('bench_mckibben', '004 (muscle.py)',
               ('g0_N_per_Pa', 'x_z_m', 'n', 'p_th_Pa', 'k_bl_N_per_m'),
               (2.8e-3, 0.15, 2.5, 1.0e4, 100.0), (1e-5, 0.02, 0.2, 0.0, 0.0),
               (0.1, 2.0, 10.0, 2.0e5, 1.0e5), force)
