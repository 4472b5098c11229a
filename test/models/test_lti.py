"""Exact ZOH against closed forms, in every damping regime (no sqrt(b^2 - 4c) anywhere)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pam_bench.models.lti import second_order_matrices, zoh


def step_response(b: float, c: float, d: float, t: float) -> float:
    """y(t) of y'' + b y' + c y = d (unit step), y(0) = y'(0) = 0, per regime."""
    y_ss = d / c
    disc = b * b - 4.0 * c
    if disc < 0:
        w = math.sqrt(-disc) / 2.0
        s = -b / 2.0
        return y_ss * (1 - math.exp(s * t) * (math.cos(w * t) - s / w * math.sin(w * t)))
    if disc == 0:
        s = -b / 2.0
        return y_ss * (1 - math.exp(s * t) * (1 - s * t))
    r1 = (-b + math.sqrt(disc)) / 2.0
    r2 = (-b - math.sqrt(disc)) / 2.0
    return y_ss * (1 + (r2 * math.exp(r1 * t) - r1 * math.exp(r2 * t)) / (r1 - r2))


@pytest.mark.parametrize('b, c', [
    (6.0, 25.0),          # underdamped
    (10.0, 25.0),         # critically damped, b^2 = 4c exactly
    (26.0, 25.0),         # overdamped
    (0.02, 1.0e4),        # very underdamped
    (2.0e3, 1.0),         # very overdamped (stiff)
])
def test_zoh_matches_closed_form(b: float, c: float) -> None:
    a, bm = second_order_matrices(b, c, c)
    h = 1e-3
    ad, bd = zoh(a, bm, h)
    x = np.zeros(2)
    for k in range(1, 501):
        x = ad @ x + bd[:, 0]
        if k % 50 == 0:
            np.testing.assert_allclose(x[0], step_response(b, c, c, k * h), rtol=1e-10,
                                       atol=1e-12)


@pytest.mark.parametrize('eps', [0.0, 1e-12, -1e-12])
def test_zoh_near_critical_is_continuous(eps: float) -> None:
    b, c = 10.0, 25.0 * (1 + eps)
    a, bm = second_order_matrices(b, c, c)
    ad, bd = zoh(a, bm, 0.5)
    ref = step_response(10.0, 25.0, 25.0, 0.5)
    assert np.all(np.isfinite(ad)) and np.all(np.isfinite(bd))
    np.testing.assert_allclose(bd[0, 0], ref, rtol=1e-9)
