"""Static gains: the isometric midline estimator against series with a known backbone."""

from __future__ import annotations

import numpy as np
import pytest

from pam_bench.analysis.static import midline_fit


def friction_series(gain_n_per_v: float, friction_n: float, turn_v: float,
                    virgin_v: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One isometric series, 0 -> 6 -> 0 V in 0.1 V steps, on the backbone
    F = gain (u - 0.5 V) with a friction of -+friction_n that changes side linearly over
    ``virgin_v`` volts after the start and ``turn_v`` volts after the turn of the sweep.

    Returns:
        (u in V, F in N, direction 0 up / 1 down), shapes (122,).
    """
    volts = np.round(np.arange(0.0, 6.0001, 0.1), 10)
    u = np.concatenate([volts, volts[::-1]])
    direction = np.repeat([0, 1], volts.size)
    travel = np.concatenate([volts, 6.0 + (6.0 - volts[::-1])])   # V swept so far
    fric = np.where(direction == 0, -friction_n * np.minimum(travel / virgin_v, 1.0),
                    friction_n * np.clip(2.0 * (travel - 6.0) / turn_v - 1.0, -1.0, 1.0))
    force = np.maximum(gain_n_per_v * (u - 0.5) + fric, 0.0)
    return u, force, direction


@pytest.mark.parametrize('gain, friction, turn_v, virgin_v', [
    (281.0, 15.0, 0.2, 0.1),      # x = 0: the friction turns within two readings
    (19.9, 15.0, 1.0, 0.5),       # x = 95 mm
    (8.55, 15.0, 2.0, 1.0),       # x = 110 mm: the down sweep rises for 1 V after the turn
    (8.55, 0.0, 0.1, 0.1),        # no friction: the backbone itself
])
def test_midline_slope_is_the_backbone_gain(gain: float, friction: float, turn_v: float,
                                            virgin_v: float) -> None:
    u, force, direction = friction_series(gain, friction, turn_v, virgin_v)
    slope, _ = midline_fit(u, force, direction)
    np.testing.assert_allclose(slope, gain, rtol=1e-9)


def test_one_sweep_gives_its_own_slope() -> None:
    u, force, direction = friction_series(100.0, 0.0, 0.1, 0.1)
    up = direction == 0
    slope, intercept = midline_fit(u[up], force[up], direction[up])
    np.testing.assert_allclose([slope, intercept], [100.0, -50.0], rtol=1e-9)


@pytest.mark.parametrize('k_up, k_down', [(2.0e4, 2.5e4), (5.0e4, 5.0e4)])
def test_isobaric_stiffness_of_a_linear_spring(k_up: float, k_down: float) -> None:
    """x = x0 - F / k on each branch: -dF/dx is k exactly, at the mid forces."""
    from pam_bench.analysis.static import isobaric_stiffness
    from pam_bench.bags.bagread import Points
    f = np.arange(50.0, 960.0, 10.0)
    n = len(f)
    force = np.concatenate([f, f[::-1]])
    x = np.concatenate([0.08 - f / k_up, 0.081 - f[::-1] / k_down])
    z = np.zeros(2 * n)
    pts = Points('isobaric', z, z.astype(int) + 2, np.arange(2 * n),
                 np.r_[np.zeros(n), np.ones(n)].astype(int), z + 2.0, force, z + 2.0, force,
                 x, z + 2e5)
    curves = isobaric_stiffness(pts)
    assert [(c['u_V'], c['branch']) for c in curves] == [(2.0, 'loading'), (2.0, 'unloading')]
    np.testing.assert_allclose(curves[0]['stiffness_N_per_m'], k_up, rtol=1e-9)
    np.testing.assert_allclose(curves[1]['stiffness_N_per_m'], k_down, rtol=1e-9)
    np.testing.assert_allclose(curves[0]['force_N'], f[:-1] + 5.0, rtol=1e-12)
