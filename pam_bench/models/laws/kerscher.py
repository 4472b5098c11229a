"""Kerscher's corrections of Tondu-Lopez (002 Eq. 2 with its e(p) and mu(k)).

F = mu pi r0^2 p [a (1 - e k)^2 - b], e = a_e exp(-p_bar) - b_e, mu = a_k exp(-40 k) - b_k,
a = 3 / tan^2 alpha0, b = 1 / sin^2 alpha0; N. a_e = 0, b_e = -e,
a_k = 0, b_k = -1 is Tondu-Lopez.
"""

from __future__ import annotations

import math

import numpy as np

from pam_bench.models.laws.base import ForceLaw

__all__ = ['force', 'LAW']


def force(th: np.ndarray, p: np.ndarray, x: np.ndarray, l0: float) -> np.ndarray:
    """002 Eq. 2 with th = (r0 m, alpha0 rad, a_e, b_e, a_k, b_k), N."""
    r0, a0, ae, be, ak, bk = th
    k = x / l0
    a, b = 3 / math.tan(a0) ** 2, 1 / math.sin(a0) ** 2
    e = ae * np.exp(-p / 1e5) - be
    mu = ak * np.exp(-40 * k) - bk
    return mu * math.pi * r0 ** 2 * p * (a * (1 - e * k) ** 2 - b)


LAW = ForceLaw('kerscher', '002 Eq. 2', ('r0_m', 'alpha0_rad', 'a_e', 'b_e', 'a_k', 'b_k'),
               (0.01, 0.35, 0.0, -1.2, 0.0, -1.0), (5e-4, 0.05, -50, -50, -50, -50),
               (0.1, 1.5, 50, 50, 50, 50), force,
               extends=('tondu_lopez', lambda th: (float(th[0]), float(th[1]), 0.0,
                                                   -float(th[2]), 0.0, -1.0)))
