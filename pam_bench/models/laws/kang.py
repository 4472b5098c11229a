"""Kang's pressure-dependent correction (003 Eq. 2) on Tondu-Lopez (002 Eq. 2).

F = q(p) pi r0^2 p [a (1 - e k)^2 - b], q = 1 + c1 exp(-c2 p_bar), N; c1 = 0 is
Tondu-Lopez. 003 calls c1 and c2
positive and q <= 1 in one breath; c1 is bounded to [-1, 10] so a fit may take either reading
(q -> 1 at high pressure, where the muscle is cylindrical).
"""

from __future__ import annotations

import numpy as np

from pam_bench.models.laws import tondu_lopez
from pam_bench.models.laws.base import ForceLaw

__all__ = ['force', 'LAW']


def force(th: np.ndarray, p: np.ndarray, x: np.ndarray, l0: float) -> np.ndarray:
    """003 Eq. 2 with th = (r0 m, alpha0 rad, e, c1, c2 per bar), N."""
    r0, a0, e, c1, c2 = th
    return (1.0 + c1 * np.exp(-c2 * p / 1e5)) * tondu_lopez.force(np.array([r0, a0, e]), p, x,
                                                                  l0)


LAW = ForceLaw('kang', '003 Eq. 2 on 002 Eq. 2', ('r0_m', 'alpha0_rad', 'e', 'c1', 'c2_per_bar'),
               (0.01, 0.35, 1.2, 0.0, 1.0), (5e-4, 0.05, 0.1, -1.0, 0.0),
               (0.1, 1.5, 20.0, 10.0, 50.0), force,
               extends=('tondu_lopez', lambda th: (*map(float, th), 0.0, 1.0)))
