"""The zoo's copy of the bench's McKibben law is the law ``MuscleModel`` evaluates."""

from __future__ import annotations

import numpy as np

from pam_bench.models.laws import bench_mckibben
from pam_bench.models.muscle import MuscleModel, MuscleParams


def test_zoo_law_equals_the_bench_muscle_without_friction() -> None:
    mp = MuscleParams(hysteresis=False)
    m = MuscleModel(mp)
    p, x = np.meshgrid(np.linspace(0.0, 6e5, 13), np.linspace(0.0, 0.14, 15))
    th = np.array([mp.gain_n_per_pa, mp.gain_zero_contraction_m, mp.gain_exponent,
                   mp.threshold_pressure_pa, mp.bladder_stiffness_n_per_m])
    want = np.array([[m.static_force(pi, xi) for pi, xi in zip(pr, xr, strict=True)]
                     for pr, xr in zip(p, x, strict=True)])
    got = np.maximum(bench_mckibben.force(th, p, x, mp.nominal_length_m), 0.0)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-9)
