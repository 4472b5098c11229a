"""Recorded series against the numpy bench at the finest exchange step."""

from __future__ import annotations

import pathlib

import numpy as np
import pytest

from pam_bench.sim.reference_check import check_recorded_series, series_readings
from pam_bench.sim.truth import scene_models
from test.analysis.bags import write_bag

VOLTS = [0.0, 3.0, 6.0]


def isotonic_bag(path: pathlib.Path, x_m: np.ndarray, held_n: float) -> None:
    seq = [(0, v) for v in VOLTS]
    write_bag(path, [dict(protocol='isotonic_quick', series=0, step=k, direction=d,
                          series_value=held_n, set_value=v, voltage=v, force=held_n,
                          contraction=float(x), pressure=0.0)
                     for k, ((d, v), x) in enumerate(zip(seq, x_m, strict=True))])


@pytest.mark.parametrize('offset_mm', [0.0, 0.25])
def test_recorded_series_against_its_reference(tmp_path: pathlib.Path,
                                               offset_mm: float) -> None:
    ref, per_reading, _ = series_readings('isotonic', 500.0, VOLTS, 0.002,
                                          models=scene_models('isotonic_quick'))
    assert per_reading == 1500 and np.all(np.diff(ref) > 0.0)   # the muscle contracts
    shifted = ref + np.array([0.0, offset_mm, 0.0]) * 1e-3
    isotonic_bag(tmp_path / 'bag', shifted, 500.0)
    [row] = check_recorded_series(tmp_path / 'bag', 'isotonic_quick',
                                  [('isotonic_quick', 500.0)], h_s=0.002)
    np.testing.assert_allclose(row['max_error'], offset_mm, atol=1e-9)
    assert row['unit'] == 'mm' and row['readings'] == 3
    if offset_mm:
        assert row['at_set_value'] == 3.0


def test_series_not_in_the_bag_is_named(tmp_path: pathlib.Path) -> None:
    isotonic_bag(tmp_path / 'bag', np.zeros(3), 500.0)
    with pytest.raises(ValueError, match='isotonic_quick at 200'):
        check_recorded_series(tmp_path / 'bag', 'isotonic_quick', [('isotonic_quick', 200.0)])
