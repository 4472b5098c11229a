"""Load cell and encoder: resolution, saturation, seeded noise."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pam_bench.models.errors import ModelError
from pam_bench.models.sensors import EncoderModel, LoadCellModel, LoadCellParams


def test_load_cell_count_and_quantisation() -> None:
    lc = LoadCellModel(LoadCellParams(noise=False))
    np.testing.assert_allclose(lc.count_n, 4000.0 / 65536, rtol=1e-15)
    f = lc.measure(123.456)
    assert abs(f - 123.456) <= lc.count_n / 2 + 1e-12
    np.testing.assert_allclose(f / lc.count_n, round(f / lc.count_n), atol=1e-9)


@pytest.mark.parametrize('force, expected', [(2500.0, 2000.0), (-3000.0, -2000.0)])
def test_load_cell_saturates(force: float, expected: float) -> None:
    lc = LoadCellModel(LoadCellParams(noise=False))
    np.testing.assert_allclose(lc.measure(force), expected)
    assert lc.saturated
    np.testing.assert_allclose(lc.voltage(force), math.copysign(10.0, force))


def test_load_cell_noise_is_seeded() -> None:
    a = [LoadCellModel(seed=7).measure(100.0) for _ in range(3)]
    b = LoadCellModel(seed=7)
    assert [b.measure(100.0) for _ in range(1)][0] == a[0]
    vals = np.array([b.measure(100.0) for _ in range(5000)])
    np.testing.assert_allclose(vals.std(), 0.2, rtol=0.1)


def test_encoder_resolution() -> None:
    enc = EncoderModel()
    np.testing.assert_allclose(enc.resolution_rad, 9.5874e-5, rtol=1e-4)
    a, _ = enc.measure(1.0, 0.01)
    assert abs(a - 1.0) <= enc.resolution_rad / 2
    assert 0.06366 / 2 * enc.resolution_rad < 0.005e-3    # finer than 004's 0.005 mm


@pytest.mark.parametrize('bad', [float('nan'), float('inf')])
def test_sensors_reject_non_finite(bad: float) -> None:
    with pytest.raises(ModelError):
        LoadCellModel().measure(bad)
    with pytest.raises(ModelError):
        EncoderModel().measure(bad, 0.01)
