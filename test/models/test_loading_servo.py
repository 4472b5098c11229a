"""Loading servo: force and position modes, torque limit, schemes agree, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from pam_bench.models.errors import ModelError
from pam_bench.models.loading_servo import LoadingServoModel, LoadingServoParams, LoadMode
from pam_bench.models.sensors import LoadCellParams
from pam_bench.sim.bench import SingleMuscleBench

QUIET = LoadCellParams(noise=False)


def test_force_limit_is_004_figure() -> None:
    s = LoadingServoModel()
    np.testing.assert_allclose(s.tau_max / s.r, 2792.0, rtol=1e-3)


@pytest.mark.parametrize('h', [0.001, 0.01])
@pytest.mark.parametrize('u, f_set', [(2.0, 200.0), (4.0, 600.0)])
def test_force_mode_reaches_set_value(h: float, u: float, f_set: float) -> None:
    b = SingleMuscleBench(load_cell=QUIET)
    b.command_valve(u)
    b.command_load(LoadMode.FORCE, f_set - 10.0)
    b.run(6.0, h)                                   # settle from rest (speed-limited travel)
    b.command_load(LoadMode.FORCE, f_set)           # one protocol step, read after 3 s
    st = b.run(3.0, h)
    np.testing.assert_allclose(st.measured_force_n, f_set, atol=1.0)


@pytest.mark.parametrize('band_n, settles', [(25.0, True), (1.0e6, False)])
def test_taking_up_the_slack_at_full_speed_settles(band_n: float, settles: bool) -> None:
    """Vent a muscle held at 50 N from 6 V (x about 107 mm): the drive crosses 107 mm of
    slack at its speed limit and overshoots on the stiff vented muscle. With the integral
    band it settles within 3 s; integrating through the slack and the overshoot (no band)
    winds the integral up and the drive cycles between slack and overload (the abort of a
    full campaign run between isobaric and isotonic)."""
    b = SingleMuscleBench(load_cell=QUIET, coupling='chained',
                          servo=LoadingServoParams(force_integral_band_n=band_n))
    b.command_valve(6.0)
    b.command_load(LoadMode.FORCE, 50.0)
    b.run(6.0, 0.01)
    assert b.x > 0.1
    b.command_valve(0.0)
    b.run(3.0, 0.01)
    late = [b.step(0.01).measured_force_n for _ in range(300)]
    assert np.all(np.isfinite(late))
    assert (np.ptp(late) < 10.0 and abs(late[-1] - 50.0) < 1.0) == settles


@pytest.mark.parametrize('scheme', ['zoh', 'rk4'])
def test_position_mode_holds(scheme: str) -> None:
    b = SingleMuscleBench(load_cell=QUIET, servo=LoadingServoParams(scheme=scheme))
    b.command_load(LoadMode.POSITION, 0.03)
    b.command_valve(5.0)
    st = b.run(3.0, 0.001)
    np.testing.assert_allclose(st.measured_angle_rad * b.servo.r, 0.03, atol=1e-5)


@pytest.mark.parametrize('scheme', ['zoh', 'rk4', 'euler'])
def test_exchange_step_of_ten_seconds(scheme: str) -> None:
    """One 10 s exchange: every scheme stays finite and the drive ends at its set value."""
    b = SingleMuscleBench(load_cell=QUIET, servo=LoadingServoParams(scheme=scheme))
    b.command_load(LoadMode.POSITION, 0.03)
    b.command_valve(3.0)
    for _ in range(3):
        st = b.step(10.0)
        assert np.isfinite([st.contraction_m, st.force_n, st.servo_torque_nm]).all()
    np.testing.assert_allclose(st.measured_angle_rad * b.servo.r, 0.03, atol=1e-4)


def test_schemes_agree() -> None:
    res = {}
    for scheme in ('zoh', 'rk4'):
        b = SingleMuscleBench(load_cell=QUIET, servo=LoadingServoParams(scheme=scheme))
        b.command_load(LoadMode.FORCE, 300.0)
        b.command_valve(3.0)
        res[scheme] = b.run(2.0, 0.001).contraction_m
    np.testing.assert_allclose(res['zoh'], res['rk4'], atol=2e-6)


def test_torque_saturates_against_a_strong_muscle() -> None:
    # stretched 5 mm at 0.6 MPa the braid lock-up pulls far more than the drive's 2792 N
    b = SingleMuscleBench(load_cell=QUIET)
    b.command_load(LoadMode.POSITION, -0.005)
    b.run(1.0, 0.01)
    b.command_valve(6.0)
    st = b.run(3.0, 0.01)
    assert b.servo.saturated
    np.testing.assert_allclose(abs(st.servo_torque_nm), b.servo.tau_max, rtol=1e-9)
    np.testing.assert_allclose(st.force_n, 2792.0, rtol=0.01)   # muscle pulls the belt back


def test_non_finite_input_raises() -> None:
    with pytest.raises(ModelError):
        LoadingServoModel().step(0.01, float('nan'), 0.0, 0.0, 0.0, 0.0)
    with pytest.raises(ModelError):
        LoadingServoModel().command(LoadMode.FORCE, float('inf'))
