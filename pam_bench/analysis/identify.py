"""Identify F'' + b F' + c F = d u (004 Eq. 2) from one force step response.

Around the working point (deviations y = F - F_a0, v = u - u0) the step of height dv at the
step instant gives y(t) = d dv s(t; b, c), where s is the unit step response of
1 / (p^2 + b p + c). It is computed exactly at the sample instants with the ZOH discretisation
(the input is constant between samples): x_k+1 = Ad x_k + Bd, realised as a 2nd-order
recursive filter from (Ad, Bd) (scipy.signal.lfilter). No closed form in the roots is used, so
under-, critically (b^2 = 4c exactly) and over-damped responses are all computed the same way.

Fit: least squares over (b, c) > 0 (in logarithms) with d and F_a0 solved linearly at every
evaluation (variable projection), the response delayed by a whole number of samples (the
measurement chain's latency) chosen by the smallest residual: delays 0, 1, ... each start from
the fit of the one before, until the residual has grown for two delays in a row (or
``max_delay``). RMS error of the fit in N.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import lfilter

from pam_bench.models.lti import second_order_matrices, zoh

__all__ = ['StepFit', 'unit_step_response', 'fit_step']


@dataclasses.dataclass(frozen=True)
class StepFit:
    """Identified coefficients: b (1/s), c (1/s^2), d (N/(V s^2)), F_a0 (N), rms (N), delay
    (samples)."""

    b: float
    c: float
    d: float
    f_a0_n: float
    rms_error_n: float
    delay_samples: int


def unit_step_response(b: float, c: float, n: int, period_s: float) -> np.ndarray:
    """s_k, k = 0..n-1, of s'' + b s' + c s = 1 (unit step at k = 0), exact at the samples."""
    ad, bd = zoh(*second_order_matrices(b, c, 1.0), period_s)
    b1, b2 = bd[0, 0], bd[1, 0]
    num = [0.0, b1, ad[0, 1] * b2 - ad[1, 1] * b1]
    den = [1.0, -(ad[0, 0] + ad[1, 1]), ad[0, 0] * ad[1, 1] - ad[0, 1] * ad[1, 0]]
    return lfilter(num, den, np.ones(n))


def _project(f: np.ndarray, s: np.ndarray, dv: float) -> tuple[float, float, np.ndarray]:
    """Best d and F_a0 for a given unit response s: linear least squares on the columns
    (s dv, 1), solved through its 2x2 normal equations (well conditioned: s is O(1/c) and
    centred below)."""
    n = len(f)
    sm, fm = float(s.sum()) / n, float(f.sum()) / n
    sc = s - sm
    den = float(sc @ sc)
    slope = float(sc @ (f - fm)) / den if den > 0.0 else 0.0
    d = slope / dv
    f0 = fm - slope * sm
    return d, f0, (slope * s + f0) - f


def fit_step(force_n: np.ndarray, period_s: float, dv: float, max_delay: int = 5) -> StepFit:
    """Fit b, c, d, F_a0 to one step response.

    Args:
        force_n: samples after the step, shape (n,), first at the step instant.
        period_s: sample period, s.
        dv: height of the voltage step, V (non-zero).
        max_delay: largest latency tried, samples.
    """
    f = np.asarray(force_n, dtype=float)
    n = len(f)
    if n < 20 or dv == 0.0:
        raise ValueError('a step response needs at least 20 samples and a non-zero step')
    def residual(theta: np.ndarray, delay: int) -> np.ndarray:
        b, c = np.exp(np.clip(theta, -30.0, 30.0))     # the optimiser may probe far out
        s = np.concatenate([np.zeros(delay), unit_step_response(b, c, n - delay, period_s)])
        return _project(f, s, dv)[2]

    start: tuple[float, np.ndarray] | None = None
    for w in (5.0, 15.0, 40.0, 100.0):
        for z in (0.2, 0.6, 1.2):
            th = np.log([2 * z * w, w * w])
            cost = float(np.sum(residual(th, 0) ** 2))
            if start is None or cost < start[0]:
                start = (cost, th)
    best: tuple[float, np.ndarray, int] | None = None
    assert start is not None
    theta = start[1]
    for delay in range(max_delay + 1):
        # each delay starts from the fit of the one before (the shape barely changes); the
        # residual is unimodal in the delay, so the search stops once it has grown twice
        sol = least_squares(residual, theta, args=(delay,), method='lm', x_scale=1.0)
        cost = float(np.sum(sol.fun ** 2))
        if best is None or cost < best[0]:
            best = (cost, sol.x, delay)
        elif delay - best[2] >= 2:
            break
        theta = sol.x
    assert best is not None
    _, theta, delay = best
    b, c = np.exp(theta)
    s = np.concatenate([np.zeros(delay), unit_step_response(b, c, n - delay, period_s)])
    d, f0, res = _project(f, s, dv)
    return StepFit(float(b), float(c), d, f0, float(np.sqrt(np.mean(res ** 2))), delay)
