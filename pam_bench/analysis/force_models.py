"""Static force models of the seeds, fitted to the same readings and compared.

Notation: gauge pressure p (Pa; p_bar = p / 1e5 where a model was written in bar), contraction
x (m), contraction ratio k = x / l0 with the nominal length l0 (m), force F (N).

- Chou-Hannaford (001 Eq. 3), 2 parameters (D0, theta0):
  F = (pi D0^2 p / 4) (1 / sin^2 theta0) [3 (1 - k)^2 cos^2 theta0 - 1]
- Tondu-Lopez with the correction factor (002 Eq. 2, mu = 1), 3 parameters (r0, alpha0, e):
  F = pi r0^2 p [a (1 - e k)^2 - b],  a = 3 / tan^2 alpha0,  b = 1 / sin^2 alpha0
- Kerscher-corrected (002 Eq. 2), 6 parameters (r0, alpha0, a_e, b_e, a_k, b_k):
  F = mu pi r0^2 p [a (1 - e k)^2 - b],  e = a_e exp(-p_bar) - b_e,  mu = a_k exp(-40 k) - b_k
- Kang's pressure-dependent correction (003 Eq. 2) on Tondu-Lopez, 5 parameters
  (r0, alpha0, e, c1, c2): F = q(p) pi r0^2 p [a (1 - e k)^2 - b], q = 1 + c1 exp(-c2 p_bar).
  003 calls c1 and c2 positive and q <= 1 in one breath; c1 is bounded to [-1, 10] so the fit
  may take either reading (q -> 1 at high pressure, where the muscle is cylindrical).
- Sarosi (002 Eq. 4), 8 parameters (a .. h), p in bar:
  F = (a p + b) exp(c k + d) + (e p + f) k + g p + h
- Al-Ibadi (003 Eq. 10-12), 4 parameters (D0, theta0, Th, s_r):
  F = p dV / dL - s_r A_in / dL - 0.641 N m / dL with the secant from the initial state
  (003 Eq. 12): dV = V(L) - V(l0), dL = l0 - L = x; V = pi (D(L) - Th)^2 L / 4 (Eq. 8-9),
  D(L) = sqrt(B^2 - L^2) / (n pi) from the inextensible braid (B = l0 / cos theta0,
  n = B sin theta0 / (pi D0), so D(l0) = D0), A_in = pi (D0 - Th)^2 / 4. As x -> 0 the
  secant tends to the tangent -dV/dL of Eq. 6, but the 1 / dL terms diverge there, so this
  model is fitted and scored on the readings with x >= 5 mm only. ``al_ibadi_tangent`` is
  the same with the tangent -dV/dL at L (Eq. 6) in place of the secant, kept to compare.

Every fit also reports each parameter's standard error from the Jacobian at the optimum,
sqrt(diag((J^T J)^-1) s^2) with s^2 the residual variance (N^2) over n - m degrees of
freedom (inf where J^T J is singular: the data do not fix that parameter).

Each model is fitted by nonlinear least squares (scipy ``least_squares``, trust region
reflective within physical bounds) on the readings where the muscle pulls; reported: RMSE, max
error (N), number of parameters, fit time (s).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.optimize import least_squares

__all__ = ['ForceModel', 'FORCE_MODELS', 'fit_force_models', 'al_ibadi_volume']

WORK_LOSS_NM = 0.641      # 003 Eq. 11: contactless loss energy of the rubber tube, N m


@dataclasses.dataclass(frozen=True)
class ForceModel:
    """A static force law F(theta, p Pa, x m, l0 m) with its start point and bounds."""

    name: str
    seed: str
    params: tuple[str, ...]
    start: tuple[float, ...]
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    law: Callable[[np.ndarray, np.ndarray, np.ndarray, float], np.ndarray]
    min_x_m: float = -math.inf


def _chou(th: np.ndarray, p: np.ndarray, x: np.ndarray, l0: float) -> np.ndarray:
    d0, t0 = th
    k = x / l0
    return (math.pi * d0 ** 2 * p / 4) / math.sin(t0) ** 2 * (
        3 * (1 - k) ** 2 * math.cos(t0) ** 2 - 1)


def _tondu(th: np.ndarray, p: np.ndarray, x: np.ndarray, l0: float) -> np.ndarray:
    r0, a0, e = th
    k = x / l0
    a, b = 3 / math.tan(a0) ** 2, 1 / math.sin(a0) ** 2
    return math.pi * r0 ** 2 * p * (a * (1 - e * k) ** 2 - b)


def _kang(th: np.ndarray, p: np.ndarray, x: np.ndarray, l0: float) -> np.ndarray:
    r0, a0, e, c1, c2 = th
    return (1.0 + c1 * np.exp(-c2 * p / 1e5)) * _tondu(np.array([r0, a0, e]), p, x, l0)


def _kerscher(th: np.ndarray, p: np.ndarray, x: np.ndarray, l0: float) -> np.ndarray:
    r0, a0, ae, be, ak, bk = th
    k = x / l0
    a, b = 3 / math.tan(a0) ** 2, 1 / math.sin(a0) ** 2
    e = ae * np.exp(-p / 1e5) - be
    mu = ak * np.exp(-40 * k) - bk
    return mu * math.pi * r0 ** 2 * p * (a * (1 - e * k) ** 2 - b)


def _sarosi(th: np.ndarray, p: np.ndarray, x: np.ndarray, l0: float) -> np.ndarray:
    a, b, c, d, e, f, g, h = th
    k, pb = x / l0, p / 1e5
    return (a * pb + b) * np.exp(c * k + d) + (e * pb + f) * k + g * pb + h


def al_ibadi_volume(length_m: np.ndarray, d0: float, t0: float, thick: float,
                    l0: float) -> np.ndarray:
    """Inner volume V(L) of 003 Eq. 8-9 with the braid's D(L) (m^3); D(l0) = D0."""
    big_b = l0 / math.cos(t0)
    n = big_b * math.sin(t0) / (math.pi * d0)
    dia = np.sqrt(np.maximum(big_b ** 2 - length_m ** 2, 0.0)) / (n * math.pi)
    return math.pi / 4 * (dia - thick) ** 2 * length_m


def _al_ibadi(th: np.ndarray, p: np.ndarray, x: np.ndarray, l0: float) -> np.ndarray:
    d0, t0, thick, s_r = th
    dl = np.maximum(x, 1e-4)
    dv = (al_ibadi_volume(l0 - dl, d0, t0, thick, l0)
          - al_ibadi_volume(np.asarray(l0), d0, t0, thick, l0))
    a_in = math.pi * (d0 - thick) ** 2 / 4
    return p * dv / dl - (s_r * a_in + WORK_LOSS_NM) / dl


def _al_ibadi_tangent(th: np.ndarray, p: np.ndarray, x: np.ndarray, l0: float) -> np.ndarray:
    d0, t0, thick, s_r = th
    dl = np.maximum(x, 1e-4)
    h = 1e-6                                             # m: central difference of V(L)
    length = l0 - dl
    dv_dl = (al_ibadi_volume(length + h, d0, t0, thick, l0)
             - al_ibadi_volume(length - h, d0, t0, thick, l0)) / (2 * h)
    a_in = math.pi * (d0 - thick) ** 2 / 4
    return -p * dv_dl - (s_r * a_in + WORK_LOSS_NM) / dl


FORCE_MODELS: tuple[ForceModel, ...] = (
    ForceModel('chou_hannaford', '001 Eq. 3', ('D0_m', 'theta0_rad'), (0.02, 0.35),
               (1e-3, 0.05), (0.2, 1.5), _chou),
    ForceModel('tondu_lopez', '002 Eq. 2 (mu = 1)', ('r0_m', 'alpha0_rad', 'e'),
               (0.01, 0.35, 1.2), (5e-4, 0.05, 0.1), (0.1, 1.5, 20.0), _tondu),
    ForceModel('kerscher', '002 Eq. 2', ('r0_m', 'alpha0_rad', 'a_e', 'b_e', 'a_k', 'b_k'),
               (0.01, 0.35, 0.0, -1.2, 0.0, -1.0), (5e-4, 0.05, -50, -50, -50, -50),
               (0.1, 1.5, 50, 50, 50, 50), _kerscher),
    ForceModel('kang', '003 Eq. 2 on 002 Eq. 2', ('r0_m', 'alpha0_rad', 'e', 'c1', 'c2_per_bar'),
               (0.01, 0.35, 1.2, 0.0, 1.0), (5e-4, 0.05, 0.1, -1.0, 0.0),
               (0.1, 1.5, 20.0, 10.0, 50.0), _kang),
    ForceModel('sarosi', '002 Eq. 4', tuple('abcdefgh'),
               (100.0, 0.0, -10.0, 0.0, -100.0, 0.0, 10.0, 0.0),
               (-1e5,) * 8, (1e5,) * 8, _sarosi),
    ForceModel('al_ibadi', '003 Eq. 12', ('D0_m', 'theta0_rad', 'Th_m', 's_r_N_per_m'),
               (0.02, 0.35, 1e-3, 100.0), (1e-3, 0.05, 0.0, 0.0), (0.2, 1.5, 5e-3, 1e7),
               _al_ibadi, min_x_m=0.005),
    ForceModel('al_ibadi_tangent', '003 Eq. 6 with Eq. 10-11',
               ('D0_m', 'theta0_rad', 'Th_m', 's_r_N_per_m'),
               (0.02, 0.35, 1e-3, 100.0), (1e-3, 0.05, 0.0, 0.0), (0.2, 1.5, 5e-3, 1e7),
               _al_ibadi_tangent, min_x_m=0.005),
)


def _standard_errors(jac: np.ndarray, residuals: np.ndarray, n_params: int) -> np.ndarray:
    """Standard error of each parameter (module docstring), shape (n_params,)."""
    dof = max(len(residuals) - n_params, 1)
    s2 = float(residuals @ residuals) / dof
    try:
        cov = np.linalg.inv(jac.T @ jac) * s2
    except np.linalg.LinAlgError:
        return np.full(n_params, np.inf)
    return np.sqrt(np.maximum(np.diag(cov), 0.0))


def fit_force_models(pressure_pa: np.ndarray, contraction_m: np.ndarray, force_n: np.ndarray,
                     nominal_length_m: float = 0.35,
                     models: tuple[ForceModel, ...] = FORCE_MODELS) -> list[dict[str, Any]]:
    """Fit every model to the readings (shapes (n,)); one dict per model for summary.json
    (model, seed, n_params, rmse_N, max_error_N, fit_s, n_points, params), plus the residuals
    under ``_residuals`` and the readings used under ``_used`` for the plots."""
    p, x, f = (np.asarray(a, dtype=float) for a in (pressure_pa, contraction_m, force_n))
    pulls = f > 0.01 * max(float(f.max(initial=0.0)), 1e-9)
    out = []
    for m in models:
        use = pulls & (x >= m.min_x_m)
        if use.sum() <= len(m.params):
            continue
        pu, xu, fu = p[use], x[use], f[use]
        scale = max(float(np.abs(fu).max()), 1.0)

        def res(th: np.ndarray, m: ForceModel = m, pu: np.ndarray = pu, xu: np.ndarray = xu,
                fu: np.ndarray = fu, scale: float = scale) -> np.ndarray:
            with np.errstate(all='ignore'):
                r = (m.law(th, pu, xu, nominal_length_m) - fu) / scale
            return np.nan_to_num(r, nan=1e3, posinf=1e3, neginf=-1e3)

        t0 = time.perf_counter()
        sol = least_squares(res, np.array(m.start), bounds=(m.lower, m.upper),
                            x_scale='jac', max_nfev=2000)
        fit_s = time.perf_counter() - t0
        r = res(sol.x) * scale
        stderr = _standard_errors(sol.jac * scale, r, len(m.params))
        out.append({'model': m.name, 'seed': m.seed, 'n_params': len(m.params),
                    'rmse_N': float(np.sqrt(np.mean(r ** 2))),
                    'max_error_N': float(np.max(np.abs(r))), 'fit_s': fit_s,
                    'n_points': int(use.sum()),
                    'params': dict(zip(m.params, map(float, sol.x), strict=True)),
                    'stderr': dict(zip(m.params, map(float, stderr), strict=True)),
                    '_residuals': r, '_used': (pu, xu, fu)})
    return out
