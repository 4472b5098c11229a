"""Sarosi's empirical law (002 Eq. 4), p in bar.

F = (a p + b) exp(c k + d) + (e p + f) k + g p + h, N, k = x / l0.
"""

from __future__ import annotations

import numpy as np

from pam_bench.models.laws.base import ForceLaw

__all__ = ['force', 'LAW']


def force(th: np.ndarray, p: np.ndarray, x: np.ndarray, l0: float) -> np.ndarray:
    """002 Eq. 4 with th = (a .. h), N."""
    a, b, c, d, e, f, g, h = th
    k, pb = x / l0, p / 1e5
    return (a * pb + b) * np.exp(c * k + d) + (e * pb + f) * k + g * pb + h


LAW = ForceLaw('sarosi', '002 Eq. 4', tuple('abcdefgh'),
               (100.0, 0.0, -10.0, 0.0, -100.0, 0.0, 10.0, 0.0), (-1e5,) * 8, (1e5,) * 8, force)
