"""Closed torque loop on the numpy twin: the identified model buys accuracy, PID alone lags."""

from __future__ import annotations

import pathlib

import numpy as np
import pytest

from pam_bench.control.inverse import InverseModel
from pam_bench.control.torque_servo import ServoMode, Signal, SignalKind
from pam_bench.twin.servo_bench import run_servo, tracking_metrics

MODEL = pathlib.Path(__file__).resolve().parents[2] / 'config' / 'inverse_model.yaml'


@pytest.fixture(scope='module')
def sin_3t() -> dict[ServoMode, dict]:
    inv = InverseModel.load(MODEL)
    sig = Signal(SignalKind.SINE, 5.0, 3.0)
    return {m: tracking_metrics(run_servo(m, sig, 3.5, inverse=inv)) for m in ServoMode}


@pytest.mark.slow
def test_controller_ordering(sin_3t: dict) -> None:
    rms = {m: r['rms_error'] for m, r in sin_3t.items()}
    assert rms[ServoMode.DYNAMIC] < rms[ServoMode.STATIC] < rms[ServoMode.PID]
    assert rms[ServoMode.DYNAMIC] < 0.3 * rms[ServoMode.PID]


def test_sin_t_within_two_percent() -> None:
    run = run_servo(ServoMode.DYNAMIC, Signal(SignalKind.SINE, 5.0, 1.0), 4.0,
                    inverse=InverseModel.load(MODEL))
    m = tracking_metrics(run)
    assert m['rms_error'] <= 0.02 * 5.0
    assert np.isfinite(run.voltage_v).all() and (run.voltage_v >= 0.0).all()
    assert (run.force_n[run.t_s > 1.0] > 20.0).all()          # both muscles stay taut


def test_metrics_find_the_reversals() -> None:
    """A synthetic run whose only error sits at the peaks of a sine."""
    from pam_bench.twin.servo_bench import ServoRun
    t = np.arange(0.0, 10.0, 1e-3)
    sp = np.sin(t)
    err = np.where(np.abs(np.cos(t)) < 0.02, 0.5, 0.01)
    run = ServoRun(t, sp, sp - err, np.cos(t), sp[:, None], sp[:, None], sp[:, None],
                   sp[:, None], 'N m')
    m = tracking_metrics(run)
    assert m['error_at_reversal'] == pytest.approx(0.5)
    assert m['error_elsewhere'] == pytest.approx(0.01)


@pytest.mark.slow
def test_servo_compare_on_the_twin_writes_metrics(tmp_path: pathlib.Path) -> None:
    import json

    from pam_bench.bringup.servo_compare import compare_servo
    rows = compare_servo(tmp_path, 'twin', ['force_verify_20mm'], duration_s=2.0)
    assert [r['controller'] for r in rows] == [m.value for m in ServoMode]
    data = json.loads((tmp_path / 'metrics.json').read_text())
    assert {'scene', 'controller', 'rms_error', 'max_error', 'error_at_reversal',
            'unit'} <= set(data[0])
    assert data[0]['unit'] == 'N' and (tmp_path / 'force_verify_20mm.png').stat().st_size > 0
