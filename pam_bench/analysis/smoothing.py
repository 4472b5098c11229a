"""Coefficients smoothed over the contraction as 004 did: polynomials in a centred, scaled x."""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ['CentredPoly', 'centred_polyfit']


@dataclasses.dataclass(frozen=True)
class CentredPoly:
    """y(x) = sum_k c_k z^k, z = (x - x_mid) / x_half, in whatever unit x was given; the
    coefficients do not depend on that unit. Residuals y - fit, shape (n,)."""

    coefficients: np.ndarray
    x_mid: float
    x_half: float
    degree: int
    residuals: np.ndarray

    @property
    def rms_residual(self) -> float:
        """Root mean square of the residuals, in the unit of y."""
        return float(np.sqrt(np.mean(self.residuals ** 2)))


def centred_polyfit(x: np.ndarray, y: np.ndarray, max_degree: int = 5) -> CentredPoly:
    """Least-squares polynomial of degree min(max_degree, n - 1) in z (004: 5th degree).

    Args:
        x: positions, shape (n,), n >= 1.
        y: values, shape (n,).
        max_degree: highest degree allowed.
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    mid, half = float((x.max() + x.min()) / 2), float((x.max() - x.min()) / 2)
    z = (x - mid) / half if half else np.zeros_like(x)
    deg = min(max_degree, len(x) - 1)
    coef = np.polynomial.polynomial.polyfit(z, y, deg)
    return CentredPoly(coef, mid, half, deg, y - np.polynomial.polynomial.polyval(z, coef))
