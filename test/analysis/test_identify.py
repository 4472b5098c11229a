"""Step identification recovers known b, c, d, F_a0 in every damping regime and with noise."""

from __future__ import annotations

import numpy as np
import pytest

from pam_bench.analysis.identify import fit_step, unit_step_response
from test.models.test_lti import step_response

T = 0.001


def synth(b: float, c: float, d: float, f0: float, dv: float, delay: int = 0,
          n: int = 1000) -> np.ndarray:
    s = np.array([step_response(b, c, 1.0, k * T) for k in range(n - delay)])
    return f0 + d * dv * np.concatenate([np.zeros(delay), s])


@pytest.mark.parametrize('b, c', [(10.0, 900.0), (20.0, 100.0), (60.0, 900.0), (40.0, 100.0)])
def test_unit_response_matches_closed_form(b: float, c: float) -> None:
    s = unit_step_response(b, c, 500, T)
    ref = np.array([step_response(b, c, 1.0, k * T) for k in range(500)])
    np.testing.assert_allclose(s, ref, rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize('b, c, d', [
    (18.8, 986.0, 2.8e4),        # underdamped, like the simulated valve at x = 0
    (60.0, 900.0, 2.0e4),        # critically damped: b^2 = 4c exactly
    (90.0, 900.0, 2.0e4),        # overdamped
    (60.0, 900.0 * (1 + 1e-12), 2.0e4),   # a hair under critical
    (60.0, 900.0 * (1 - 1e-12), 2.0e4),   # a hair over critical
    (2.0, 2500.0, 5.0e4),        # very underdamped (zeta = 0.02)
    (400.0, 900.0, 2.0e4),       # very overdamped (zeta = 6.7)
])
def test_fit_recovers_coefficients(b: float, c: float, d: float) -> None:
    f = synth(b, c, d, 300.0, 0.2, delay=2)
    fit = fit_step(f, T, 0.2)
    np.testing.assert_allclose([fit.b, fit.c, fit.d, fit.f_a0_n], [b, c, d, 300.0], rtol=1e-4)
    assert fit.delay_samples == 2 and fit.rms_error_n < 1e-6


def test_fit_with_noise_and_outliers() -> None:
    rng = np.random.default_rng(1)
    f = synth(18.8, 986.0, 2.8e4, 300.0, 0.2)
    amp = np.ptp(f)
    noisy = f + rng.normal(0, 0.05 * amp, f.size)
    noisy[rng.choice(f.size, 10, replace=False)] += 0.5 * amp
    fit = fit_step(noisy, T, 0.2)
    np.testing.assert_allclose([fit.b, fit.c, fit.d], [18.8, 986.0, 2.8e4], rtol=0.15)
    assert np.isfinite(fit.rms_error_n)


def test_too_short_rejected() -> None:
    with pytest.raises(ValueError):
        fit_step(np.ones(5), T, 0.2)
