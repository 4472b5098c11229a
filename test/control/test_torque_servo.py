"""Torque servo control law: force split, PID anti-windup, set-point signals."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pam_bench.control.torque_servo import (
    Pid,
    ServoMode,
    Signal,
    SignalKind,
    TorqueServoController,
    TorqueServoParams,
    split_torque,
)
from pam_bench.models.errors import ModelError

R = 0.06366 / 2


@pytest.mark.parametrize('torque', [-25.46, -10.0, -1.0, 0.0, 2.5, 10.0, 25.46])
def test_split_makes_the_torque_and_keeps_both_taut(torque: float) -> None:
    (f1, *_), (f2, *_) = split_torque(torque, 0.0, 0.0, R, 300.0, 50.0)
    np.testing.assert_allclose(R * (f1 - f2), torque, rtol=0, atol=1e-12)
    assert min(f1, f2) >= 50.0 - 1e-9


@pytest.mark.parametrize('torque, rate', [(5.0, 3.0), (-5.0, -2.0), (20.0, 4.0),
                                           (-20.0, 1.0)])
def test_split_rates_are_the_derivative(torque: float, rate: float) -> None:
    h = 1e-7
    a1, a2 = split_torque(torque, rate, 0.0, R, 300.0, 50.0)
    b1, b2 = split_torque(torque + rate * h, rate, 0.0, R, 300.0, 50.0)
    np.testing.assert_allclose([(b1[0] - a1[0]) / h, (b2[0] - a2[0]) / h], [a1[1], a2[1]],
                               rtol=1e-5)


def test_pid_integral_stops_while_clamped() -> None:
    pid = Pid(0.0, 1.0, 0.0, 0.01, 0.0, 6.0)
    for _ in range(1000):
        out = pid.step(100.0, 0.01, feedforward=5.0)   # would need +100 V: clamped
    assert out <= 1.0 + 1e-9                   # integral stopped at the clamp, no windup
    recovered = pid.step(-1.0, 0.01, feedforward=5.0)
    assert recovered < out


def test_pid_derivative_filter_is_exact_first_order() -> None:
    pid = Pid(0.0, 0.0, 1.0, 0.1, -1e9, 1e9)
    pid.step(0.0, 0.01)
    out = [pid.step(0.01 * (k + 1), 0.01) for k in range(200)]     # ramp: e' = 1
    np.testing.assert_allclose(out[-1], 1.0, rtol=1e-6)
    np.testing.assert_allclose(out[0], 1.0 - math.exp(-0.1), rtol=1e-12)


@pytest.mark.parametrize('kind, t, expect', [
    (SignalKind.SINE, 0.5, (1.0 + 5 * math.sin(1.5), 15 * math.cos(1.5),
                            -45 * math.sin(1.5))),
    (SignalKind.SQUARE, 0.4, (6.0, 0.0, 0.0)),
    (SignalKind.SQUARE, 2.0, (-4.0, 0.0, 0.0)),
    (SignalKind.CONSTANT, 7.0, (1.0, 0.0, 0.0)),
])
def test_signals(kind: SignalKind, t: float, expect: tuple[float, float, float]) -> None:
    s = Signal(kind, 5.0, 3.0, 1.0, 3.0)
    np.testing.assert_allclose(s.value_and_rates(t), expect, rtol=1e-12)


def test_controller_needs_a_model_for_feedforward() -> None:
    with pytest.raises(ModelError, match='inverse model'):
        TorqueServoController(TorqueServoParams(), ServoMode.DYNAMIC, None)


def test_clamp_torque() -> None:
    ctl = TorqueServoController(TorqueServoParams(), ServoMode.PID, None)
    assert ctl.clamp_torque(30.0) == (25.46, True)
    assert ctl.clamp_torque(-3.0) == (-3.0, False)
