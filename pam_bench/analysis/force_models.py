"""Static force models of the seeds, fitted to the same readings and compared.

The laws themselves, one module per law with its equation and seed, are in
``pam_bench.models.laws`` (the zoo the bench's muscles share): Chou-Hannaford, Tondu-Lopez,
Kerscher, Kang, Sarosi, Al-Ibadi (secant as printed and the tangent variant), the
straight-fibre graph of 000 read backwards and the bench's own McKibben law.

Every fit also reports each parameter's standard error from the Jacobian at the optimum,
sqrt(diag((J^T J)^-1) s^2) with s^2 the residual variance (N^2) over n - m degrees of
freedom (inf where J^T J is singular: the data do not fix that parameter).

Each model is fitted by nonlinear least squares (scipy ``least_squares``, trust region
reflective within physical bounds) on the readings where the muscle pulls, from its start
point and, for a law that extends another (Kang and Kerscher extend Tondu-Lopez), also from
the other's optimum, keeping the better; reported: RMSE, max
error (N), number of parameters, fit time (s).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from pam_bench.models.laws.base import ForceLaw
from pam_bench.models.laws.zoo import FORCE_LAWS

__all__ = ['FORCE_MODELS', 'fit_force_models']

FORCE_MODELS = FORCE_LAWS
"""The laws compared, in report order (``pam_bench.models.laws.zoo``)."""


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
                     models: tuple[ForceLaw, ...] = FORCE_MODELS) -> list[dict[str, Any]]:
    """Fit every model to the readings (shapes (n,)); one dict per model for summary.json
    (model, seed, n_params, rmse_N, max_error_N, fit_s, n_points, params), plus the residuals
    under ``_residuals`` and the readings used under ``_used`` for the plots."""
    p, x, f = (np.asarray(a, dtype=float) for a in (pressure_pa, contraction_m, force_n))
    pulls = f > 0.01 * max(float(f.max(initial=0.0)), 1e-9)
    out = []
    fitted: dict[str, np.ndarray] = {}
    for m in models:
        use = pulls & (x >= m.min_x_m)
        if use.sum() <= len(m.params):
            continue
        pu, xu, fu = p[use], x[use], f[use]
        scale = max(float(np.abs(fu).max()), 1.0)

        def res(th: np.ndarray, m: ForceLaw = m, pu: np.ndarray = pu, xu: np.ndarray = xu,
                fu: np.ndarray = fu, scale: float = scale) -> np.ndarray:
            with np.errstate(all='ignore'):
                r = (m.law(th, pu, xu, nominal_length_m) - fu) / scale
            return np.nan_to_num(r, nan=1e3, posinf=1e3, neginf=-1e3)

        t0 = time.perf_counter()
        starts = [np.array(m.start)]
        parent = fitted.get(m.extends[0]) if m.extends else None
        if m.extends and parent is not None:
            starts.append(np.clip(m.extends[1](parent), m.lower, m.upper))
        sol = min((least_squares(res, s0, bounds=(m.lower, m.upper), x_scale='jac',
                                 max_nfev=2000) for s0 in starts), key=lambda s: s.cost)
        fit_s = time.perf_counter() - t0
        fitted[m.name] = sol.x
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
