"""Al-Ibadi's contraction muscle (003): force (Eq. 10-12), length (Eq. 17-18) and stiffness
(Eq. 19).

Volume (003 Eq. 8-9): V(L) = pi (D(L) - Th)^2 L / 4 with the inextensible braid's
D(L) = sqrt(B^2 - L^2) / (n pi), B = l0 / cos theta0, n = B sin theta0 / (pi D0), so
D(l0) = D0; Th the wall (m); A_in = pi (D0 - Th)^2 / 4 (m^2).

Force (003 Eq. 12): F = p dV / dL - s_r A_in / dL - 0.641 N m / dL, with the secant from the
initial state as printed: dV = V(L) - V(l0), dL = l0 - L = x. As x -> 0 the secant tends to
the tangent -dV/dL of Eq. 6, but the 1 / dL terms diverge there, so the law is fitted and
scored on readings with x >= 5 mm only. ``TANGENT`` is the same law with the tangent -dV/dL at
L (Eq. 6) in place of the secant, kept as a named variant (BENCHMARKS.md, 'The
straight-fibre muscle', its law table).

Length (003 Eq. 17-18): L = L0 - a L0 / (1 + exp(-b (D0 / s_r) p))^6.214, with
a = 0.0126 + 14882 q - 2e8 q^2 and b = 2e-5 - 0.5375 q + 11777 q^2, q = D0 / s_r (m per N/m:
actuator diameter D0 in m over the inner tube's stiffness s_r in N/m). a is the largest
contraction ratio the law allows: checked against 003's Table 6 (A 29 %, B 19.5 %, C 24.3 %,
D 28.6 % for its Table 5 actuators; ``max_contraction_ratio``). The exponent b q p as printed
is far below 1 for any bench pressure in Pa (about 1e-9 p), so the law is kept as printed and
the pressure unit it was fitted in is left an open question: only ``a`` is used to judge a
muscle here.

Length of [12] (003 Eq. 14): L = a + b / [1 + (P_g / c)^d]^e - 0.009 L0 sqrt(P_g), with a .. e
linear in (L0, L0^-0.248, L0^2, L0^3) by the printed matrix (L0, L in m). Read with P_g in bar,
the unit of 003's tests (0 to 5 bar): a + b = L0 exactly (no contraction without pressure), and
at L0 = 0.2 m the contraction grows from 25.8 % at 1 bar to 28.9 % at 5 bar; with P_g in kPa it
would reach 52 %, beyond any braid. The printed c is negative for every L0 of its range (-0.0020
at 0.15 m, -0.0027 at 0.2 m, -0.0051 at 0.4 m), which makes (P_g / c)^d undefined for the
fractional d (0.08 .. 0.22); |c| is used (``length_eq14``). Eq. 14 holds no diameter or
rubber stiffness, so it cannot tell Table 6's A, B and C apart (all 0.2 m): at 5 bar it gives
28.9 % for all three (Table 6: 29 / 19.5 / 24.3 %) and 30.6 % for D at 0.3 m (28.6 %); that
is why 003 replaces it with Eq. 17.

Stiffness (003 Eq. 19, from Eq. 12): s = p dV / dL^2 - f_rs / dL - f_c / dL with
f_rs = s_r A_in / dL (Eq. 10) and f_c = 0.641 N m / dL (Eq. 11); N/m.
"""

from __future__ import annotations

import math

import numpy as np

from pam_bench.models.laws.base import ForceLaw

__all__ = ['WORK_LOSS_NM', 'volume', 'force', 'force_tangent', 'LAW', 'TANGENT',
           'length_coefficients', 'max_contraction_ratio', 'length', 'length_eq14',
           'eq14_coefficients', 'stiffness']

WORK_LOSS_NM = 0.641
"""003 Eq. 11: contactless loss energy of the rubber tube, N m."""
_A = (0.0126, 14882.0, -2.0e8)
_B = (2.0e-5, -0.5375, 11777.0)
EXPONENT = 6.214


def volume(length_m: np.ndarray, d0: float, t0: float, thick: float, l0: float) -> np.ndarray:
    """Inner volume V(L) of 003 Eq. 8-9 with the braid's D(L) (m^3); D(l0) = D0."""
    big_b = l0 / math.cos(t0)
    n = big_b * math.sin(t0) / (math.pi * d0)
    dia = np.sqrt(np.maximum(big_b ** 2 - length_m ** 2, 0.0)) / (n * math.pi)
    return math.pi / 4 * (dia - thick) ** 2 * length_m


def force(th: np.ndarray, p: np.ndarray, x: np.ndarray, l0: float) -> np.ndarray:
    """003 Eq. 12 (secant) with th = (D0 m, theta0 rad, Th m, s_r N/m), N."""
    d0, t0, thick, s_r = th
    dl = np.maximum(x, 1e-4)
    dv = volume(l0 - dl, d0, t0, thick, l0) - volume(np.asarray(l0), d0, t0, thick, l0)
    a_in = math.pi * (d0 - thick) ** 2 / 4
    return p * dv / dl - (s_r * a_in + WORK_LOSS_NM) / dl


def force_tangent(th: np.ndarray, p: np.ndarray, x: np.ndarray, l0: float) -> np.ndarray:
    """003 Eq. 6 with Eq. 10-11 (tangent -dV/dL at L), th as ``force``, N."""
    d0, t0, thick, s_r = th
    dl = np.maximum(x, 1e-4)
    h = 1e-6                                             # m: central difference of V(L)
    length_m = l0 - dl
    dv_dl = (volume(length_m + h, d0, t0, thick, l0)
             - volume(length_m - h, d0, t0, thick, l0)) / (2 * h)
    a_in = math.pi * (d0 - thick) ** 2 / 4
    return -p * dv_dl - (s_r * a_in + WORK_LOSS_NM) / dl


_NAMES = ('D0_m', 'theta0_rad', 'Th_m', 's_r_N_per_m')
_START, _LOW, _HIGH = (0.02, 0.35, 1e-3, 100.0), (1e-3, 0.05, 0.0, 0.0), (0.2, 1.5, 5e-3, 1e7)
LAW = ForceLaw('al_ibadi', '003 Eq. 12', _NAMES, _START, _LOW, _HIGH, force, min_x_m=0.005)
TANGENT = ForceLaw('al_ibadi_tangent', '003 Eq. 6 with Eq. 10-11', _NAMES, _START, _LOW, _HIGH,
                   force_tangent, min_x_m=0.005)


def length_coefficients(d0_m: float, s_r_n_per_m: float) -> tuple[float, float]:
    """(a, b) of 003 Eq. 18 for an actuator of diameter ``d0_m`` (m) and inner-tube stiffness
    ``s_r_n_per_m`` (N/m)."""
    q = d0_m / s_r_n_per_m
    return (_A[0] + _A[1] * q + _A[2] * q * q, _B[0] + _B[1] * q + _B[2] * q * q)


def max_contraction_ratio(d0_m: float, s_r_n_per_m: float) -> float:
    """The largest contraction ratio (L0 - L) / L0 of 003 Eq. 17: its coefficient a, -."""
    return length_coefficients(d0_m, s_r_n_per_m)[0]


def length(p_pa: np.ndarray, l0_m: float, d0_m: float, s_r_n_per_m: float) -> np.ndarray:
    """L(p) of 003 Eq. 17 as printed (module docstring), m; shape of ``p_pa``."""
    a, b = length_coefficients(d0_m, s_r_n_per_m)
    q = d0_m / s_r_n_per_m
    return l0_m - a * l0_m / (1.0 + np.exp(-b * q * np.asarray(p_pa, float))) ** EXPONENT


_EQ14 = np.array([[0.4351, 0.0, 0.0183, -0.0003],
                  [0.5649, 0.0, -0.0183, 0.0003],
                  [-0.0141, 0.0, 0.0031, -0.00006],
                  [0.5487, 0.0, -0.0136, 0.00007],
                  [0.0, 0.3694, 0.0, 0.0]])


def eq14_coefficients(l0_m: float) -> tuple[float, float, float, float, float]:
    """(a m, b m, c bar as printed, d, e) of 003 Eq. 14 for a free length ``l0_m``."""
    a, b, c, d, e = _EQ14 @ np.array([l0_m, l0_m ** -0.248, l0_m ** 2, l0_m ** 3])
    return float(a), float(b), float(c), float(d), float(e)


def length_eq14(p_pa: np.ndarray, l0_m: float) -> np.ndarray:
    """L(p) of 003 Eq. 14 with P_g in bar and |c| (module docstring), m; shape of ``p_pa``."""
    a, b, c, d, e = eq14_coefficients(l0_m)
    pg = np.maximum(np.asarray(p_pa, float), 0.0) / 1e5
    return a + b / (1.0 + (pg / abs(c)) ** d) ** e - 0.009 * l0_m * np.sqrt(pg)


def stiffness(p_pa: np.ndarray, x_m: np.ndarray, l0_m: float, d0_m: float, theta0_rad: float,
              thick_m: float, s_r_n_per_m: float) -> np.ndarray:
    """003 Eq. 19: s = (p dV / dL - f_rs - f_c) / dL at contraction ``x_m`` = dL, N/m."""
    th = np.array([d0_m, theta0_rad, thick_m, s_r_n_per_m])
    dl = np.maximum(np.asarray(x_m, float), 1e-4)
    return force(th, np.asarray(p_pa, float), dl, l0_m) / dl
