"""Reading-by-reading comparison of two bags (verify.wallclock.compare_readings)."""

from __future__ import annotations

import pathlib

import numpy as np

from pam_bench.verify.wallclock import compare_readings
from test.analysis.bags import write_bag


def _points(contraction_6v_m: float) -> list[dict]:
    """Two isobaric readings at 2 V and one at 6 V, 50 N (the one a calibration leaves out)."""
    rows = [(0, 2.0, 50.0, 0.070), (1, 2.0, 150.0, 0.048), (2, 6.0, 50.0, contraction_6v_m)]
    return [dict(protocol='isobaric_quick', series=0 if u == 2.0 else 1, step=k, direction=0,
                 series_value=u, set_value=f, voltage=u, force=f, contraction=x, pressure=u * 1e5)
            for k, u, f, x in rows]


def test_skipped_readings_do_not_count(tmp_path: pathlib.Path) -> None:
    write_bag(tmp_path / 'a', _points(0.112))
    write_bag(tmp_path / 'b', _points(0.120))
    every = compare_readings(tmp_path / 'a', tmp_path / 'b')
    assert every.matched == 3
    np.testing.assert_allclose(every.max_contraction_m, 0.008, atol=1e-12)
    kept = compare_readings(tmp_path / 'a', tmp_path / 'b', skip=[('isobaric', 6.0, 50.0)])
    assert kept.matched == 2
    np.testing.assert_allclose(kept.max_contraction_m, 0.0, atol=1e-12)
