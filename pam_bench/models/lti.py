"""Exact discretisation of linear time-invariant dynamics under a zero-order hold.

For x' = A x + B u with u constant over a step h, the exact update is
x(t + h) = Ad x(t) + Bd u with [[Ad, Bd], [0, I]] = expm([[A, B], [0, 0]] h) (Van Loan).
No closed form in the eigenvalues is used, so every damping regime (under-, critically and
over-damped, b^2 = 4c exactly) is handled by the same stable computation.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import expm

__all__ = ['zoh', 'second_order_matrices', 'ZohCache']


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
    blk = np.zeros((n + m, n + m))
    blk[:n, :n] = a
    blk[:n, n:] = b
    e = expm(blk * h)
    return e[:n, :n], e[:n, n:]


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

    def get(self, key: tuple, a: np.ndarray, b: np.ndarray, h: float
            ) -> tuple[np.ndarray, np.ndarray]:
        """(Ad, Bd) for the system named ``key`` over step ``h``."""
        k = (key, h)
        hit = self._store.get(k)
        if hit is None:
            if len(self._store) >= self._size:
                self._store.pop(next(iter(self._store)))
            hit = zoh(a, b, h)
            self._store[k] = hit
        return hit
