"""Valve: steady state 0.1 MPa/V, exact dynamics, clamps and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from pam_bench.models.errors import ModelError
from pam_bench.models.valve import ValveModel, ValveParams


@pytest.mark.parametrize('order', [0, 1, 2])
@pytest.mark.parametrize('u, p_ss', [(0.0, 0.0), (1.0, 1e5), (6.0, 6e5), (10.0, 1e6)])
def test_steady_state(order: int, u: float, p_ss: float) -> None:
    v = ValveModel(ValveParams(order=order, volume_scaling=False))
    for _ in range(200):
        v.step(u, 0.05)
    np.testing.assert_allclose(v.pressure, p_ss, rtol=1e-9, atol=1e-6)


@pytest.mark.parametrize('u, p_expected', [(-3.0, 0.0), (12.0, 1e6)])
def test_voltage_clamped(u: float, p_expected: float) -> None:
    v = ValveModel(ValveParams(order=0))
    np.testing.assert_allclose(v.step(u, 0.01), p_expected)


def test_first_order_exact() -> None:
    v = ValveModel(ValveParams(order=1, time_constant_s=0.03))
    p = v.step(5.0, 0.07)
    np.testing.assert_allclose(p, 5e5 * (1 - math.exp(-0.07 / 0.03)), rtol=1e-12)


def test_second_order_matches_radau() -> None:
    prm = ValveParams(order=2, natural_frequency_rad_s=31.4, damping_ratio=0.3,
                      volume_scaling=False)
    v = ValveModel(prm)
    w, z = prm.natural_frequency_rad_s, prm.damping_ratio
    sol = solve_ivp(lambda t, y: [y[1], w * w * (4e5 - y[0]) - 2 * z * w * y[1]], (0, 1.0),
                    [0.0, 0.0], method='Radau', rtol=1e-12, atol=1e-6, dense_output=True)
    for k in range(1, 101):
        v.step(4.0, 0.01)
        np.testing.assert_allclose(v.state[0], sol.sol(k * 0.01)[0], rtol=1e-7, atol=1e-2)


def test_oscillating_step_overshoots_and_output_stays_in_range() -> None:
    v = ValveModel(ValveParams(order=2, damping_ratio=0.3))
    peak = max(v.step(10.0, 0.001, 1.1e-4) for _ in range(500))
    assert v.state[0] > 1e6 * 0.99
    assert peak <= 1e6          # reported pressure clamped to the valve's 1 MPa range


def test_frequency_falls_with_volume() -> None:
    v = ValveModel(ValveParams())
    assert v.natural_frequency(3e-4) < v.natural_frequency(1e-4)


def test_stable_for_step_100x_time_constant() -> None:
    v = ValveModel(ValveParams(order=2, natural_frequency_rad_s=1e4, damping_ratio=0.7))
    for _ in range(20):
        p = v.step(3.0, 10.0)
        assert math.isfinite(p)
    np.testing.assert_allclose(p, 3e5, rtol=1e-12)


@pytest.mark.parametrize('order', [1, 2])
def test_step_of_ten_seconds_lands_on_steady_state(order: int) -> None:
    v = ValveModel(ValveParams(order=order))
    p = v.step(4.0, 10.0, 1e-4)
    assert math.isfinite(p)
    np.testing.assert_allclose(p, 4e5, rtol=1e-9)


@pytest.mark.parametrize('u', [float('nan'), float('inf'), -float('inf')])
def test_non_finite_voltage_raises(u: float) -> None:
    with pytest.raises(ModelError):
        ValveModel().step(u, 0.01)


def test_transient_requests_wait_for_volume_evidence_after_the_command() -> None:
    """A volume report from before the command change says nothing about the transient it
    started: the valve asks for short exchanges until an exchange of transient_step_s after
    the change shows the volume standing still."""
    from pam_bench.models.valve import VolumeEvidence
    v = ValveModel()
    ev = VolumeEvidence()
    ev.volume(0.0, 1.0e-4)
    ev.volume(3.0, 1.0e-4)                # still, but before the change
    ev.command_changed(3.0)
    v.step(3.0, 0.001, 1.0e-4)            # the pressure is in transient
    assert v.max_step(3.0, ev) == v.p.transient_step_s
    ev.volume(3.001, 1.0e-4)              # after the change, but a 1 ms span
    assert v.max_step(3.0, ev) == v.p.transient_step_s
    ev.volume(3.101, 1.0e-4)              # 0.1 s after the change, still: any step
    assert v.max_step(3.0, ev) == 0.0
    ev.volume(3.201, 1.01e-4)             # moving (10 %/s): short steps again
    assert v.max_step(3.0, ev) == v.p.transient_step_s
