"""The simulated bench lands on the 004 figures (issue tolerances)."""

from __future__ import annotations

import pytest

from pam_bench.verify.calibration import calibration_figures


@pytest.fixture(scope='module')
def figures() -> dict[str, float]:
    return calibration_figures()


def test_isometric_gain_at_0mm(figures: dict[str, float]) -> None:
    assert abs(figures['isometric_gain_N_per_V_at_0mm'] / 284.0 - 1) <= 0.10


def test_isometric_gain_at_95mm(figures: dict[str, float]) -> None:
    assert abs(figures['isometric_gain_N_per_V_at_95mm'] / 17.0 - 1) <= 0.30


def test_contraction_and_force(figures: dict[str, float]) -> None:
    assert figures['contraction_mm_at_6V_50N'] >= 100.0
    assert figures['force_N_at_6V_0mm'] >= 900.0


def test_visible_hysteresis(figures: dict[str, float]) -> None:
    assert figures['isobaric_hysteresis_mm_max'] > 1.0
