"""Step records at long exchange steps against the 1 ms exchange (numpy bench)."""

from __future__ import annotations

import numpy as np
import pytest

from pam_bench.analysis.identify import fit_step
from pam_bench.sim.record_exchange import record_step


@pytest.mark.parametrize(('x_m', 'u0', 'u1', 'tol'), [(0.04, 1.0, 5.0, 0.01),
                                                      (0.08, 5.0, 1.0, 0.01)])
def test_10ms_record_matches_1ms(x_m: float, u0: float, u1: float, tol: float) -> None:
    ref, n_ref = record_step(x_m, u0, u1, 0.001)
    rec, n = record_step(x_m, u0, u1, 0.01)
    assert (n_ref, n) == (1000, 100)
    assert np.all(np.isfinite(rec))
    fr, ft = fit_step(ref, 0.001, u1 - u0), fit_step(rec, 0.001, u1 - u0)
    np.testing.assert_allclose([ft.b, ft.c, ft.d], [fr.b, fr.c, fr.d], rtol=tol)


def test_sub_samples_follow_the_pressure_path() -> None:
    """Without sub-samples a 50 ms exchange records a staircase; with them, the step."""
    rec, _ = record_step(0.04, 1.0, 5.0, 0.05)
    steps = np.count_nonzero(np.abs(np.diff(rec[:200])) > 1.0)
    assert steps > 100           # the force moves at (nearly) every 1 ms sample


def test_chained_and_jacobi_agree_at_1ms() -> None:
    """The couplings differ by the exchange delays only (two 1 ms hops)."""
    a, _ = record_step(0.04, 1.0, 5.0, 0.001, coupling='chained')
    b, _ = record_step(0.04, 1.0, 5.0, 0.001, coupling='jacobi')
    fa, fb = fit_step(a, 0.001, 4.0), fit_step(b, 0.001, 4.0)
    np.testing.assert_allclose([fb.b, fb.c, fb.d], [fa.b, fa.c, fa.d], rtol=0.03)
