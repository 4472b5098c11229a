"""The zoo's copy of the bench's McKibben law is the law ``MuscleModel`` evaluates."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pam_bench.models.laws import bench_mckibben
from pam_bench.models.muscle import MuscleModel, MuscleParams

SHAPED = dict(gain_min_n_per_pa=1.8e-4, gain_min_contraction_m=0.095, gain_exponent=2.2,
              gain_rise_n_per_pa_m=2e-4, threshold_pressure_pa=8e4, threshold_width_pa=3e4,
              bladder_stiffness_n_per_m=400.0)


@pytest.mark.parametrize('shape', [{}, SHAPED], ids=['defaults', 'shaped'])
def test_zoo_law_equals_the_bench_muscle_without_friction(shape: dict) -> None:
    mp = dataclasses.replace(MuscleParams(hysteresis=False), **shape)
    m = MuscleModel(mp)
    p, x = np.meshgrid(np.linspace(0.0, 6e5, 13), np.linspace(0.0, 0.13, 14))
    th = np.array([mp.gain_n_per_pa, mp.gain_min_n_per_pa, mp.gain_min_contraction_m,
                   mp.gain_exponent, mp.gain_rise_n_per_pa_m, mp.threshold_pressure_pa,
                   mp.threshold_width_pa, mp.bladder_stiffness_n_per_m])
    want = np.array([[m.static_force(pi, xi) for pi, xi in zip(pr, xr, strict=True)]
                     for pr, xr in zip(p, x, strict=True)])
    got = np.maximum(bench_mckibben.force(th, p, x, mp.nominal_length_m), 0.0)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-9)
