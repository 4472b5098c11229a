"""Tondu-Lopez with the correction factor (002 Eq. 2, mu = 1): the braid ends that do not
take the cylinder's shape shorten the useful length.

F = pi r0^2 p [a (1 - e k)^2 - b], a = 3 / tan^2 alpha0, b = 1 / sin^2 alpha0; r0 nominal
radius (m), alpha0 nominal braid angle (rad), e the end correction (-), k = x / l0; N.
"""

from __future__ import annotations

import math

import numpy as np

from pam_bench.models.laws.base import ForceLaw

__all__ = ['force', 'LAW']


def force(th: np.ndarray, p: np.ndarray, x: np.ndarray, l0: float) -> np.ndarray:
    """002 Eq. 2 (mu = 1) with th = (r0 m, alpha0 rad, e), N."""
    r0, a0, e = th
    k = x / l0
    a, b = 3 / math.tan(a0) ** 2, 1 / math.sin(a0) ** 2
    return math.pi * r0 ** 2 * p * (a * (1 - e * k) ** 2 - b)


LAW = ForceLaw('tondu_lopez', '002 Eq. 2 (mu = 1)', ('r0_m', 'alpha0_rad', 'e'),
               (0.01, 0.35, 1.2), (5e-4, 0.05, 0.1), (0.1, 1.5, 20.0), force)
