"""Schedules of the 004 protocols and the sequencer state machine."""

from __future__ import annotations

import numpy as np
import pytest

from pam_bench.models.errors import ParameterError
from pam_bench.models.loading_servo import LoadMode
from pam_bench.models.protocols import (
    Direction,
    Measurement,
    Phase,
    Sequencer,
    schedule_from_config,
    sweep,
)

FULL = {
    'isometric': {'kind': 'isometric', 'x_m': [0.0, 0.110, 0.005], 'voltage_v': [0, 6, 0.1]},
    'isotonic': {'kind': 'isotonic', 'force_n': [50, 950, 50], 'voltage_v': [0, 6, 0.1]},
    'isobaric': {'kind': 'isobaric', 'voltage_v': [0, 6, 1], 'force_n': [50, 950, 10]},
}


@pytest.mark.parametrize('name, points', [('isometric', 2806), ('isotonic', 2318),
                                          ('isobaric', 1274)])
def test_full_grid_point_counts(name: str, points: int) -> None:
    readings, _ = schedule_from_config(name, FULL[name])
    assert len(readings) == points


def test_sweep_is_exact_on_grid() -> None:
    np.testing.assert_allclose(sweep(0.0, 6.0, 0.1)[-1], 6.0, rtol=0, atol=0)
    assert len(sweep(0.0, 6.0, 0.1)) == 61


def test_up_then_down_per_series() -> None:
    readings, _ = schedule_from_config('isometric', FULL['isometric'])
    first = readings[:122]
    assert [r.direction for r in first] == [Direction.UP] * 61 + [Direction.DOWN] * 61
    assert [r.voltage_v for r in first[:61]] == [r.voltage_v for r in first[61:]][::-1]
    assert all(r.load_mode == LoadMode.POSITION for r in first)


def test_sequencer_reads_after_each_dwell() -> None:
    readings, settle = schedule_from_config(
        'q', {'kind': 'isotonic', 'force_n': [100, 200, 100], 'voltage_v': [0, 1, 0.5],
              'dwell_s': 3.0, 'settle_s': 2.0})
    seq = Sequencer('q', readings, settle)
    seq.start(0.0)
    h, t, times = 0.01, 0.0, []
    meas = Measurement(1.0, 2.0, 3.0)
    while seq.phase not in (Phase.DONE,) and t < 100:
        t = round(t + h, 9)
        cmd = seq.tick(t, meas)
        if cmd.point is not None:
            times.append(cmd.point.t_s)
    assert len(times) == len(readings) == 12
    np.testing.assert_allclose(np.diff(times), 3.0, atol=1e-9)
    np.testing.assert_allclose(times[0], 5.0, atol=1e-9)
    assert seq.tick(t + h, meas).voltage_v == 0.0            # vented when done


def test_missing_key_named() -> None:
    with pytest.raises(ParameterError, match="'x_m'"):
        schedule_from_config('bad', {'kind': 'isometric', 'voltage_v': [0, 6, 1]})
