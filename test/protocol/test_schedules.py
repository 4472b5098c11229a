"""Schedules of the 004 protocols: point counts, ordering, campaigns, resume."""

from __future__ import annotations

import numpy as np
import pytest

from pam_bench.models.loading_servo import LoadMode
from pam_bench.protocol.schedules import Direction, resume_index, schedule_from_config, sweep
from pam_bench.vocabulary.errors import ParameterError

FULL = {
    'isometric': {'kind': 'isometric', 'x_m': [0.0, 0.110, 0.005], 'voltage_v': [0, 6, 0.1]},
    'isotonic': {'kind': 'isotonic', 'force_n': [50, 950, 50], 'voltage_v': [0, 6, 0.1]},
    'isobaric': {'kind': 'isobaric', 'voltage_v': [0, 6, 1], 'force_n': [50, 950, 10]},
}
QUICK_ISO = {'kind': 'isometric', 'x_m': [0.0, 0.080, 0.040], 'voltage_v': [0, 6, 1]}


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


STEP = {'kind': 'step_response', 'x_m': [0.0, 0.080, 0.005],
        'up': {'u0_v': 1.0, 'step_v': 0.2, 'n': 20},
        'down': {'u0_v': 5.0, 'step_v': -0.2, 'n': 20},
        'record_s': 1.0, 'sample_period_s': 0.001}


def test_step_response_schedule() -> None:
    readings, _ = schedule_from_config('step_response', STEP)
    assert len(readings) == 17 * 40
    first = readings[:40]
    assert [r.voltage_v for r in first[:20]] == pytest.approx([1 + 0.2 * n for n in range(1, 21)])
    assert [r.voltage_v for r in first[20:]] == pytest.approx([5 - 0.2 * n for n in range(1, 21)])
    assert {r.pre_voltage_v for r in first[:20]} == {1.0}


def test_campaign_concatenates() -> None:
    table = {'a': FULL['isobaric'], 'b': FULL['isotonic'], 'c': {'kind': 'campaign',
                                                                  'protocols': ['a', 'b']}}
    readings, _ = schedule_from_config('c', table['c'], table)
    assert len(readings) == 1274 + 2318
    assert readings[1274].lead_s == 3.0 and readings[1274].protocol == 'b'


def test_missing_key_named() -> None:
    with pytest.raises(ParameterError, match="'x_m'"):
        schedule_from_config('bad', {'kind': 'isometric', 'voltage_v': [0, 6, 1]})


def test_resume_index_restarts_at_the_first_reading_not_taken() -> None:
    table = {'a': FULL['isometric'], 'b': FULL['isotonic'], 'c': {'kind': 'campaign',
                                                                  'protocols': ['a', 'b']}}
    readings, _ = schedule_from_config('c', table['c'], table)
    keys = [(r.protocol, r.series, r.step) for r in readings]
    assert resume_index(readings, set()) == 0
    assert resume_index(readings, set(keys)) == len(readings)
    # cut in the middle of isometric series 5: restart at the reading that was next
    cut = keys.index(('a', 5, 0)) + 40
    assert resume_index(readings, set(keys[:cut])) == cut
    # isometric complete, isotonic not started: restart at the campaign's second protocol
    n_a = sum(1 for k in keys if k[0] == 'a')
    assert resume_index(readings, set(keys[:n_a])) == n_a
