"""A series on the numpy twin, and a recorded run against its numpy twin."""

from __future__ import annotations

import pathlib

import numpy as np
import pytest

from pam_bench.bags.bagread import read_bags
from pam_bench.twin.protocol_run import run_protocol
from pam_bench.verify.reference_check import compare_run, series_readings
from pam_bench.verify.truth import scene_models
from test.analysis.bags import write_bag


def test_series_readings_contract_and_take_few_exchanges() -> None:
    ref, per_reading, _ = series_readings('isotonic', 500.0, [0.0, 3.0, 6.0], 3.0, 0.002,
                                          models=scene_models('isotonic_quick'))
    assert per_reading < 10 and np.all(np.diff(ref) > 0.0)     # the muscle contracts


def _bag_of(path: pathlib.Path, twin: object, offset_mm: float) -> None:
    pts = []
    for i, p in enumerate(twin.points):
        r, m = p.reading, p.measurement
        x = m.contraction_m + (offset_mm * 1e-3 if i == 5 else 0.0)
        pts.append(dict(protocol=r.protocol, series=r.series, step=r.step,
                        direction=int(r.direction), series_value=r.series_value,
                        set_value=r.set_value, voltage=p.voltage_v, force=m.force_n,
                        contraction=x, pressure=m.pressure_pa))
    write_bag(path, pts)


@pytest.mark.parametrize('offset_mm', [0.0, 0.25])
def test_run_against_its_twin_finds_a_moved_reading(tmp_path: pathlib.Path,
                                                    offset_mm: float) -> None:
    twin = run_protocol('isotonic_quick', 3.0)
    _bag_of(tmp_path / 'bag', twin, offset_mm)
    [row] = compare_run(read_bags([tmp_path / 'bag']), twin)['protocols']
    assert row['protocol'] == 'isotonic_quick' and row['readings'] == 42
    assert row['unit'] == 'mm'
    np.testing.assert_allclose(row['max_error'], offset_mm, atol=1e-9)


def test_a_bag_without_the_twins_readings_is_named(tmp_path: pathlib.Path) -> None:
    twin = run_protocol('isotonic_quick', 3.0)
    short = run_protocol('isotonic_quick', 3.0, overrides={'force_n': [200.0, 200.0, 300.0]})
    _bag_of(tmp_path / 'bag', short, 0.0)
    with pytest.raises(ValueError, match='isotonic_quick'):
        compare_run(read_bags([tmp_path / 'bag']), twin)


def test_a_step_whose_reference_does_not_move_is_counted_not_compared() -> None:
    """A step below the muscle's first pull gives the noise-free twin a flat record: it has
    no b, c, d to divide by (a full campaign's 1.0 -> 1.2 V step at x = 95 mm did)."""
    from types import SimpleNamespace
    t = np.arange(1000) * 1e-3
    rise = 40.0 * (1.0 - np.exp(-t / 0.05))
    rec = SimpleNamespace(voltage_initial_v=1.0, voltage_final_v=1.2, sample_period_s=1e-3)
    data = SimpleNamespace(points={}, records=[
        SimpleNamespace(**vars(rec), force_n=rise), SimpleNamespace(**vars(rec),
                                                                     force_n=np.zeros(1000))])
    twin = SimpleNamespace(points=[], records=[SimpleNamespace(samples=rise),
                                               SimpleNamespace(samples=np.zeros(1000))])
    out = compare_run(data, twin)['records']
    assert out['records'] == 1 and out['flat_references'] == 1
    assert out['max_bcd_rel_error'] < 1e-9
