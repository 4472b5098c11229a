"""Chou-Hannaford's ideal McKibben muscle (001 Eq. 3): inextensible braid, thin bladder.

F = (pi D0^2 p / 4) (1 / sin^2 theta0) [3 (1 - k)^2 cos^2 theta0 - 1], N, with D0 the nominal
diameter (m), theta0 the nominal braid angle (rad), k = x / l0.
"""

from __future__ import annotations

import math

import numpy as np

from pam_bench.models.laws.base import ForceLaw

__all__ = ['force', 'LAW']


def force(th: np.ndarray, p: np.ndarray, x: np.ndarray, l0: float) -> np.ndarray:
    """001 Eq. 3 with th = (D0 m, theta0 rad), N."""
    d0, t0 = th
    k = x / l0
    return (math.pi * d0 ** 2 * p / 4) / math.sin(t0) ** 2 * (
        3 * (1 - k) ** 2 * math.cos(t0) ** 2 - 1)


LAW = ForceLaw('chou_hannaford', '001 Eq. 3', ('D0_m', 'theta0_rad'), (0.02, 0.35),
               (1e-3, 0.05), (0.2, 1.5), force)
