"""Muscle: gains at the 004 points, clamps, volume, hysteresis without chatter."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pam_bench.models.friction import MaxwellSlip
from pam_bench.models.muscle import MuscleModel, MuscleParams

KV = 1e5     # Pa per V (004: p = 0.1 u MPa)


def test_gain_curve_ends() -> None:
    """g(0) = g_0 and g(x_m) = g_m, the smallest (004's figures as the extraction reads them:
    test/verify/test_calibration.py)."""
    m = MuscleModel()
    np.testing.assert_allclose(m.gain(0.0), m.p.gain_n_per_pa, rtol=1e-12)
    np.testing.assert_allclose(m.gain(m.p.gain_min_contraction_m), m.p.gain_min_n_per_pa,
                               rtol=1e-12)
    assert min(m.gain(x) for x in np.linspace(0.0, 0.11, 111)) * KV == pytest.approx(
        m.p.gain_min_n_per_pa * KV, rel=1e-9)


@pytest.mark.parametrize('p_pa, x_m', [(0.0, 0.0), (6e5, 0.2), (1e6, 0.15), (6e5, 0.5),
                                       (1e5, 0.1), (0.0, 0.05)])
def test_force_never_negative(p_pa: float, x_m: float) -> None:
    out = MuscleModel().step(p_pa, x_m)
    assert out.force_n >= 0.0 and np.isfinite(out.force_n)


def test_force_zero_beyond_the_braid_lock() -> None:
    m = MuscleModel(MuscleParams(hysteresis=False))
    for x in (m.lock_contraction_m + 0.002, m.lock_contraction_m * 1.5, 1.0):
        assert m.step(1e6, x).force_n == 0.0


@pytest.mark.parametrize('x_m', [-0.01, 0.0, 0.05, 0.149, 0.15, 0.3])
@pytest.mark.parametrize('p_pa', [0.0, 1.0e6])
def test_zero_and_maximum_pressure(p_pa: float, x_m: float) -> None:
    """The valve's two ends (0 and 1 MPa) at every contraction: real, finite, never pushing."""
    m = MuscleModel()
    out = m.step(p_pa, x_m)
    vals = [out.force_n, out.stiffness_n_per_m, out.friction_n, out.volume_m3]
    assert all(isinstance(v, float) and math.isfinite(v) for v in vals)
    assert out.force_n >= 0.0 and out.volume_m3 > 0.0
    if p_pa == 0.0 and x_m >= 0.0:
        assert out.force_n == 0.0
    if x_m >= 0.15:
        assert out.force_n == 0.0


def test_threshold_little_force_below_threshold_pressure() -> None:
    """The contact band: below p_th - 2 w the muscle pulls less than 5 % of what it pulls at
    p_th + 2 w; with w = 0 nothing at all below p_th."""
    m = MuscleModel(MuscleParams(hysteresis=False))
    pth, w = m.p.threshold_pressure_pa, m.p.threshold_width_pa
    low, high = m.step(max(pth - 2 * w, 0.0), 0.0).force_n, m.step(pth + 2 * w, 0.0).force_n
    assert 0.0 <= low < 0.05 * high
    sharp = MuscleModel(MuscleParams(hysteresis=False, threshold_width_pa=0.0))
    assert sharp.step(0.5 * pth, 0.0).force_n == 0.0
    assert sharp.step(2.0 * pth, 0.0).force_n > 0.0


def test_volume_grows_with_contraction_and_matches_cylinder_at_rest() -> None:
    m = MuscleModel()
    v0 = np.pi * 0.01 ** 2 * 0.35
    np.testing.assert_allclose(m.volume(0.0), v0, rtol=1e-12)
    vs = [m.volume(x) for x in np.linspace(0, 0.11, 12)]
    assert np.all(np.diff(vs) > 0)


def test_stiffness_matches_finite_difference() -> None:
    m = MuscleModel(MuscleParams(hysteresis=False))
    p, x, h = 4e5, 0.04, 1e-7
    k = m.backbone_stiffness(p, x)
    fd = -(m.backbone(p, x + h) - m.backbone(p, x - h)) / (2 * h)
    np.testing.assert_allclose(k, fd, rtol=1e-6)


def test_isometric_hysteresis_up_below_down() -> None:
    m = MuscleModel()
    x = 0.02
    up = [m.step(p, x).force_n for p in np.linspace(0, 6e5, 61)]
    down = [m.step(p, x).force_n for p in np.linspace(6e5, 0, 61)]
    diff = np.array(down[::-1]) - np.array(up)
    assert diff[30] > 5.0           # unloading curve above the loading curve


def test_friction_no_chatter_at_reversal() -> None:
    f = MaxwellSlip([3e5, 1e5, 4e4], [1.0, 2.0, 2.0], [0.0, 0.0, 0.0])
    f.force(0.01, 0.0)
    # dither of 1e-9 m around a reversal: force changes by at most k * 2e-9 per move
    vals = [f.force(0.01 + (1e-9 if i % 2 else -1e-9), 0.0) for i in range(100)]
    assert np.ptp(vals) <= 4.4e5 * 2e-9 * 1.0001


@pytest.mark.parametrize('n_steps', [10, 100, 1000])
def test_friction_rate_independent(n_steps: int) -> None:
    f = MaxwellSlip([3e5, 1e5, 4e4], [1.0, 2.0, 2.0], [0.004, 0.008, 0.012])
    path = np.concatenate([np.linspace(0, 1e-3, n_steps), np.linspace(1e-3, 4e-4, n_steps)])
    for s in path:
        out = f.force(s, 300.0)
    ref = MaxwellSlip([3e5, 1e5, 4e4], [1.0, 2.0, 2.0], [0.004, 0.008, 0.012])
    ref.force(1e-3, 300.0)
    np.testing.assert_allclose(out, ref.force(4e-4, 300.0), rtol=1e-12)
    assert abs(out) <= sum([1.0 + 0.004 * 300, 2.0 + 0.008 * 300, 2.0 + 0.012 * 300]) + 1e-9


@pytest.mark.parametrize('x_m', [0.0, 0.04, 0.08, 0.11, 0.14])
@pytest.mark.parametrize('direction', [1.0, -1.0])
def test_friction_never_reverses_the_force(x_m: float, direction: float) -> None:
    """At held x the force follows the pressure: up never lowers it, down never raises it,
    through every stick-slip transition (the braid friction is a reaction, not a source)."""
    m = MuscleModel()
    p_path = np.linspace(0.0, 6e5, 601)
    for p in p_path:                      # load up first, then run the tested direction
        m.step(float(p), x_m)
    path = p_path if direction > 0 else p_path[::-1]
    forces = np.array([m.step(float(p), x_m).force_n for p in path])
    assert np.all(direction * np.diff(forces) >= -1e-9)


def test_trial_leaves_no_friction_trace_and_commit_equals_step() -> None:
    """The coupled solve tries several positions per sub-step: a trial must not move the
    friction, and committing a trial must be the same as stepping there."""
    a, b = MuscleModel(), MuscleModel()
    for pa, x in ((1e5, 0.04), (3e5, 0.041), (5e5, 0.039), (2e5, 0.0405)):
        for probe in (x - 1e-3, x + 1e-3):
            b.trial(pa, probe)
        assert b.friction.z == a.friction.z
        ref = a.step(pa, x)
        t = b.trial(pa, x)
        b.commit(t)
        assert (t[0], t[1], t[2]) == (ref.force_n, ref.stiffness_n_per_m, ref.friction_n)
    assert b.friction.z == a.friction.z and b.friction.sticking == a.friction.sticking


def test_friction_rejects_a_zero_stiffness_element() -> None:
    with pytest.raises(ValueError):
        MaxwellSlip([3e5, 0.0], [1.0, 2.0], [0.0, 0.0])


SHAPED = MuscleParams(gain_min_n_per_pa=1.8e-4, gain_min_contraction_m=0.095, gain_exponent=1.5,
                      gain_rise_n_per_pa_m=2.5e-4, threshold_pressure_pa=8e4,
                      threshold_width_pa=4e4, bladder_stiffness_n_per_m=350.0,
                      hysteresis=False)


@pytest.mark.parametrize('p_pa', [0.0, 1e3, 5e4, 8e4, 2e5, 6e5, 1e6])
def test_effective_pressure_is_a_smooth_ramp(p_pa: float) -> None:
    """e(0) = 0, de/dp the logistic of (p - p_th) / w, and e -> p - p_th - w ln(1 + e^(-p_th/w))
    at high pressure; w = 0 is the sharp threshold."""
    m = MuscleModel(SHAPED)
    w, pth = SHAPED.threshold_width_pa, SHAPED.threshold_pressure_pa
    e, de = m.effective_pressure(p_pa)
    h = 1.0
    slope = (m.effective_pressure(p_pa + h)[0] - m.effective_pressure(max(p_pa - h, 0.0))[0]) / (
        p_pa + h - max(p_pa - h, 0.0))
    np.testing.assert_allclose(de, 1 / (1 + math.exp(-(p_pa - pth) / w)), rtol=1e-12)
    np.testing.assert_allclose(slope, de, rtol=1e-3, atol=1e-6)
    if p_pa == 0.0:
        assert e == 0.0
    if p_pa == 1e6:
        np.testing.assert_allclose(e, p_pa - pth - w * math.log1p(math.exp(-pth / w)),
                                   rtol=1e-9)
    sharp = MuscleModel(MuscleParams(threshold_width_pa=0.0, threshold_pressure_pa=pth))
    assert sharp.effective_pressure(p_pa)[0] == max(p_pa - pth, 0.0)


def test_gain_is_continuous_with_its_minimum_at_x_m() -> None:
    m = MuscleModel(SHAPED)
    xm = SHAPED.gain_min_contraction_m
    xs = np.linspace(0.0, 0.13, 261)
    g = np.array([m.gain(x) for x in xs])
    assert xs[int(np.argmin(g))] == pytest.approx(xm, abs=1e-3)
    np.testing.assert_allclose(m.gain(xm - 1e-9), m.gain(xm + 1e-9), rtol=1e-6)
    np.testing.assert_allclose(m.gain(0.0), SHAPED.gain_n_per_pa, rtol=1e-12)
    np.testing.assert_allclose(m.gain(xm), SHAPED.gain_min_n_per_pa, rtol=1e-12)


@pytest.mark.parametrize('x_m', [-0.002, 0.01, 0.05, 0.09, 0.1, 0.12, 0.14])
@pytest.mark.parametrize('p_pa', [3e4, 2e5, 6e5])
def test_stiffness_is_minus_the_slope_of_the_backbone(x_m: float, p_pa: float) -> None:
    m = MuscleModel(SHAPED)
    h = 1e-7
    slope = -(m.backbone(p_pa, x_m + h) - m.backbone(p_pa, x_m - h)) / (2 * h)
    np.testing.assert_allclose(m.backbone_stiffness(p_pa, x_m), slope, rtol=1e-5, atol=1e-3)


def test_the_braid_locks_at_its_largest_contraction() -> None:
    """x_l = l_n - b cos(54.74 deg): 134.9 mm for 004's muscle; past it the muscle is slack."""
    m = MuscleModel(SHAPED)
    b = 0.35 / math.cos(math.radians(20.0))
    np.testing.assert_allclose(m.lock_contraction_m, 0.35 - b / math.sqrt(3.0), rtol=1e-12)
    assert m.static_force(1e6, m.lock_contraction_m - 1e-3) > 0.0
    assert m.static_force(1e6, m.lock_contraction_m + 2e-3) == 0.0


def test_a_gain_rise_that_would_make_the_muscle_unstable_is_refused() -> None:
    from pam_bench.models.errors import ModelError
    with pytest.raises(ModelError, match='gain_rise_n_per_pa_m'):
        MuscleModel(MuscleParams(gain_rise_n_per_pa_m=1e-3, bladder_stiffness_n_per_m=500.0))
