"""003's length and stiffness laws of a contraction muscle (Al-Ibadi et al.), for comparison
with what a bench measures.

Length (003 Eq. 17-18): L = L0 - a L0 / (1 + exp(-b (D0 / s_r) p))^6.214, with
a = 0.0126 + 14882 q - 2e8 q^2 and b = 2e-5 - 0.5375 q + 11777 q^2, q = D0 / s_r (m per N/m:
actuator diameter D0 in m over the inner tube's stiffness s_r in N/m). a is the largest
contraction ratio the law allows: checked against 003's Table 6 (A 29 %, B 19.5 %, C 24.3 %,
D 28.6 % for its Table 5 actuators; ``max_contraction_ratio``). The exponent b q p as printed
is far below 1 for any bench pressure in Pa (about 1e-9 p), so the law is kept as printed
and the pressure unit it was fitted in is left an open question: only ``a`` is used to judge
a muscle here.

Stiffness (003 Eq. 19, from Eq. 12): s = p dV / dL^2 - f_rs / dL - f_c / dL with the secant
volume change dV = V(L) - V(L0), dL = L0 - L (m), f_rs = s_r A_in / dL (Eq. 10) and
f_c = 0.641 N m / dL (Eq. 11); N/m.
"""

from __future__ import annotations

import math

import numpy as np

from pam_bench.analysis.force_models import WORK_LOSS_NM, al_ibadi_volume

__all__ = ['length_coefficients', 'max_contraction_ratio', 'al_ibadi_length',
           'al_ibadi_stiffness']

_A = (0.0126, 14882.0, -2.0e8)
_B = (2.0e-5, -0.5375, 11777.0)
EXPONENT = 6.214


def length_coefficients(d0_m: float, s_r_n_per_m: float) -> tuple[float, float]:
    """(a, b) of 003 Eq. 18 for an actuator of diameter ``d0_m`` (m) and inner-tube stiffness
    ``s_r_n_per_m`` (N/m)."""
    q = d0_m / s_r_n_per_m
    return (_A[0] + _A[1] * q + _A[2] * q * q, _B[0] + _B[1] * q + _B[2] * q * q)


def max_contraction_ratio(d0_m: float, s_r_n_per_m: float) -> float:
    """The largest contraction ratio (L0 - L) / L0 of 003 Eq. 17: its coefficient a, -."""
    return length_coefficients(d0_m, s_r_n_per_m)[0]


def al_ibadi_length(p_pa: np.ndarray, l0_m: float, d0_m: float, s_r_n_per_m: float
                    ) -> np.ndarray:
    """L(p) of 003 Eq. 17 as printed (module docstring), m; shape of ``p_pa``."""
    a, b = length_coefficients(d0_m, s_r_n_per_m)
    q = d0_m / s_r_n_per_m
    return l0_m - a * l0_m / (1.0 + np.exp(-b * q * np.asarray(p_pa, float))) ** EXPONENT


def al_ibadi_stiffness(p_pa: np.ndarray, x_m: np.ndarray, l0_m: float, d0_m: float,
                       theta0_rad: float, thick_m: float, s_r_n_per_m: float) -> np.ndarray:
    """003 Eq. 19: s = (p dV / dL - f_rs - f_c) / dL at contraction ``x_m`` = dL, N/m."""
    dl = np.maximum(np.asarray(x_m, float), 1e-4)
    dv = (al_ibadi_volume(l0_m - dl, d0_m, theta0_rad, thick_m, l0_m)
          - al_ibadi_volume(np.asarray(l0_m), d0_m, theta0_rad, thick_m, l0_m))
    a_in = math.pi * (d0_m - thick_m) ** 2 / 4
    return (np.asarray(p_pa, float) * dv / dl - (s_r_n_per_m * a_in + WORK_LOSS_NM) / dl) / dl
