"""Fit the bench's muscle to 004's figures (``pam-bench calibrate --target 004``).

Nonlinear least squares (scipy ``least_squares``, trust region reflective within bounds) over
the muscle parameters of ``FREE`` (their declared ranges narrowed to where the law is stable
and physical), on residuals built from ``pam_bench.verify.figures_004.measure_004`` (004's
full grids on the quasi-static bench, read by the extraction's own estimators):

- isometric gain at 0 mm against 284.3 N/V, at 95 mm against 17.4 N/V (per cent), and a
  hinge that is zero when every other position's gain is at least 0.1 N/V above the 95 mm
  one (the minimum at 95 mm);
- isotonic gain at (0.85 V, 50 N) against 97.16 mm/V and the largest isotonic gain against the
  same (so it is the maximum, at 004's place: the grid's mid voltages are 0.05 V apart), a
  hinge keeping every gain more than 0.15 V away from 0.86 V below 90 % of it, the gain at
  (0.05 V, 100 N) against 0.13 mm/V (in 0.001 mm/V: its tolerance is 20 %, 0.026 mm/V, and
  in hundredths it gave way to the per-cent terms at 0.061 mm/V);
- hinges for the bounds: contraction >= 100 mm, force >= 900 N, servo torque >= 25.46 N m.

The gain's minimum sits at x_m = 95 mm (004's place, held fixed). Each parameter's standard
error and the correlations come from the Jacobian at the optimum, sqrt(diag((J^T J)^+) s^2)
with s^2 the residual variance (``covariance``); a parameter whose error exceeds its value,
or that is at a bound, is flagged: the figures do not fix it.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any, TypedDict

import numpy as np
from scipy.optimize import least_squares

from pam_bench.models.errors import ModelError
from pam_bench.models.muscle import MuscleParams
from pam_bench.verify.figures_004 import figure_rows, measure_004
from pam_bench.vocabulary.errors import ParameterError

__all__ = ['fit_report', 'FREE', 'residuals_004', 'calibrate_004', 'fit_summary', 'covariance',
           'FitSummary', 'Calibration004', 'residual_variance']


class FitSummary(TypedDict):
    """A least-squares fit's parameters (``fit_summary``): their names in order, values and
    standard errors by name (the parameters' units), the correlation matrix (names x names),
    the names the data do not fix (flags) or that sit at a bound, one line per name."""

    names: list[str]
    values: dict[str, float]
    stderr: dict[str, float]
    correlation: list[list[float]]
    flags: list[str]
    at_bound: list[str]
    report: dict[str, str]


class Calibration004(FitSummary):
    """``calibrate_004``'s result: the fit, the fitted muscle's values (``params``), 004's
    figures at the optimum (``figure_rows``), the cost, evaluations and seconds taken."""

    params: dict[str, Any]
    figures: list[dict[str, Any]]
    cost: float
    evaluations: int
    fit_s: float

FREE: tuple[tuple[str, float, float], ...] = (
    ('gain_n_per_pa', 2.0e-3, 4.0e-3),
    ('gain_min_n_per_pa', 1.0e-4, 3.0e-4),
    ('gain_exponent', 1.2, 4.0),
    ('gain_rise_n_per_pa_m', 0.0, 1.0e-3),
    ('threshold_pressure_pa', 2.0e4, 1.5e5),
    ('threshold_width_pa', 5.0e3, 8.0e4),
    ('bladder_stiffness_n_per_m', 100.0, 2000.0),
    ('stretch_stiffness_n_per_m', 1.0e5, 1.0e6),
    ('friction_stiffness_scale', 0.1, 2.0),
)
"""(parameter, lower, upper) fitted to 004's figures; the rest keep their values.
``friction_stiffness_scale`` multiplies every friction element's stiffness k_i (their ratios
and break forces stay): it sets how far the braid moves before its friction slides."""
GAIN_MIN_AT_M = 0.095


def _params(theta: np.ndarray, base: MuscleParams) -> MuscleParams:
    values: dict[str, Any] = {name: float(v) for (name, _, _), v in zip(FREE, theta,
                                                                       strict=True)}
    scale = values.pop('friction_stiffness_scale')
    return dataclasses.replace(base, gain_min_contraction_m=GAIN_MIN_AT_M,
                               friction_stiffness_n_per_m=[
                                   k * scale for k in base.friction_stiffness_n_per_m], **values)


def _value(params: MuscleParams, name: str, base: MuscleParams) -> float:
    if name == 'friction_stiffness_scale':
        return params.friction_stiffness_n_per_m[0] / base.friction_stiffness_n_per_m[0]
    return float(getattr(params, name))


def residuals_004(measured: dict[str, Any]) -> np.ndarray:
    """The residual vector of the module docstring, from ``measure_004``'s output."""
    iso = measured['isometric_gain_by_x']
    k95 = iso['95']
    hinge = [max(0.0, k95 + 0.1 - k) for x, k in iso.items() if x != '95']
    ton = measured['isotonic_by_point']
    elsewhere = max((k for key, k in ton.items()
                     if abs(float(key.split(',')[0]) - 0.86) > 0.15), default=0.0)
    return np.array([
        (measured['isometric_gain_max'] - 284.3) / 284.3 * 100.0,
        (k95 - 17.4) / 17.4 * 100.0,
        *(10.0 * h for h in hinge),
        (ton.get('0.85,50', 0.0) - 97.16) / 97.16 * 100.0,
        (measured['isotonic_gain_max'] - 97.16) / 97.16 * 100.0,
        max(0.0, elsewhere - 0.9 * 97.16) / 97.16 * 300.0,
        (measured['isotonic_gain_at_0v_100n'] - 0.13) / 0.001,
        max(0.0, 100.0 - measured['contraction_max']),
        max(0.0, 900.0 - measured['force_max']) / 10.0,
        max(0.0, 25.46 - measured['servo_torque_max']) * 10.0,
    ])


def residual_variance(residuals: np.ndarray, n: int) -> float:
    """s^2 = |r|^2 / (m - n) of m residuals left by a fit of n parameters (one degree of
    freedom at least), in the residuals' units squared."""
    r = np.asarray(residuals, dtype=float)
    return float(r @ r) / max(len(r) - n, 1)


def covariance(jac: np.ndarray, s2: float) -> tuple[np.ndarray, np.ndarray]:
    """Covariance and correlation of a least-squares estimate from its Jacobian.

    cov = s^2 (J^T J)^+ built from the SVD J = U S V^T as s^2 V S^-2 V^T, singular values
    below eps max(shape) S_max dropped (as scipy's ``curve_fit`` does). Built this way the
    matrix is symmetric positive semi-definite, so every correlation
    cov_ij / sqrt(cov_ii cov_jj) lies in [-1, 1] up to rounding; a direction the Jacobian
    does not see gives a zero variance and zero correlations, not a huge one.

    Args:
        jac: (m, n) Jacobian of the residuals (the prior's rows included when the residuals
            carry them, so the covariance is the posterior's).
        s2: residual variance.

    Returns:
        (n, n) covariance and (n, n) correlation.
    """
    _, sv, vt = np.linalg.svd(jac, full_matrices=False)
    keep = sv > np.finfo(float).eps * max(jac.shape) * (sv[0] if sv.size else 0.0)
    sv, vt = sv[keep], vt[keep]
    cov = (vt.T / sv ** 2) @ vt * s2
    cov = 0.5 * (cov + cov.T)
    sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
    with np.errstate(all='ignore'):
        corr = np.where(np.outer(sd, sd) > 0, cov / np.outer(sd, sd), 0.0)
    np.fill_diagonal(corr, np.where(sd > 0, 1.0, 0.0))
    return cov, np.clip(corr, -1.0, 1.0)      # the clip only trims rounding (test)


def fit_summary(names: list[str], theta: np.ndarray, sol: Any, span: np.ndarray,
                rel_flag: float) -> FitSummary:
    """Values, standard errors, correlations and flags of a ``least_squares`` solution found
    in coordinates z = (theta - lower) / span (module docstring). The covariance is taken in z,
    where the Jacobian's columns share one scale (``covariance``), and scaled back by span; a
    parameter is flagged when its standard error exceeds ``rel_flag`` times its value, or it
    sits at a bound (z = 0 or 1)."""
    cov_z, corr = covariance(sol.jac, residual_variance(sol.fun, len(names)))
    stderr = np.sqrt(np.maximum(np.diag(cov_z), 0.0)) * span
    at_bound = (sol.x <= 1e-6) | (sol.x >= 1 - 1e-6)
    flags = [n for n, v, e, b in zip(names, theta, stderr, at_bound, strict=True)
             if b or not np.isfinite(e) or e > rel_flag * abs(v)]
    bound_names = [n for n, b in zip(names, at_bound, strict=True) if b]
    out = FitSummary(names=names, values=dict(zip(names, map(float, theta), strict=True)),
                     stderr=dict(zip(names, map(float, stderr), strict=True)),
                     correlation=corr.round(3).tolist(), flags=flags, at_bound=bound_names,
                     report={})
    out['report'] = fit_report(out)
    return out


def fit_report(summary: FitSummary, unfixed: str = 'not fixed by these recordings'
               ) -> dict[str, str]:
    """One line per parameter: its value with its standard error; a value at a bound of the
    fit says so instead, and one the data do not fix gives no standard error (an error of
    1e-11 from residuals near zero would claim what the data do not show)."""
    out = {}
    for n in summary['names']:
        v, e = summary['values'][n], summary['stderr'][n]
        if n in summary.get('at_bound', []):
            out[n] = f'{v:12.5g}  (at its bound: the recordings push it there)'
        elif n in summary['flags']:
            out[n] = f'{v:12.5g}  ({unfixed})'
        else:
            out[n] = f'{v:12.5g} +- {e:.2g}'
    return out


def calibrate_004(base: MuscleParams | None = None, max_nfev: int = 60) -> Calibration004:
    """Fit ``FREE`` to 004's figures from ``base`` (default: the bench's defaults).

    Returns:
        params (the fitted values), stderr, correlation (names x names), flags (names the data
        do not fix), figures (``figure_rows`` at the optimum), cost, evaluations, fit_s.
    """
    base = base or MuscleParams()
    names = [n for n, _, _ in FREE]
    lower = np.array([lo for _, lo, _ in FREE])
    upper = np.array([hi for _, _, hi in FREE])
    scale = upper - lower

    def res(z: np.ndarray) -> np.ndarray:
        try:
            return residuals_004(measure_004(muscle=_params(lower + z * scale, base)))
        except (ModelError, ParameterError):
            return np.full(len(res0), 1e3)

    start = np.array([1.0 if n == 'friction_stiffness_scale' else _value(base, n, base)
                      for n in names])
    z0 = np.clip((start - lower) / scale, 0.0, 1.0)
    res0 = residuals_004(measure_004(muscle=_params(lower + z0 * scale, base)))
    t0 = time.perf_counter()
    sol = least_squares(res, z0, bounds=(0.0, 1.0), diff_step=1e-3, max_nfev=max_nfev)
    fit_s = time.perf_counter() - t0
    theta = lower + sol.x * scale
    summary = fit_summary(names, theta, sol, scale, rel_flag=1.0)
    fitted = _params(theta, base)
    keep = [n for n in names if n != 'friction_stiffness_scale']
    params: dict[str, Any] = {n: float(getattr(fitted, n))
                              for n in keep + ['gain_min_contraction_m']}
    params['friction_stiffness_n_per_m'] = list(fitted.friction_stiffness_n_per_m)
    return Calibration004(**summary, params=params,
                          figures=figure_rows(measure_004(muscle=fitted)), cost=float(sol.cost),
                          evaluations=int(sol.nfev), fit_s=fit_s)
