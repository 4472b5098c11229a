"""Step records in one exchange against one exchange per sample (numpy bench)."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.record_exchange import record_step
from pam_bench.analysis.identify import fit_step


@pytest.mark.parametrize(('x_m', 'u0', 'u1'), [(0.04, 1.0, 5.0), (0.08, 5.0, 1.0)])
@pytest.mark.parametrize('h', [0.01, 1.0])
def test_long_exchange_record_equals_the_1ms_record(x_m: float, u0: float, u1: float,
                                                   h: float) -> None:
    """The samples are solved on the same 1 ms sub-steps whatever the exchange; what is left
    is the chamber volume the valve holds over an exchange (the belt stretches by F / k_b,
    up to 0.5 mm, so its natural frequency moves by a few 1e-4): every sample within 1.5 N
    (0.2 %) of a 400 to 1200 N step, b, c, d within 0.5 % (the fit amplifies: 0.2 % at
    40 mm)."""
    ref, n_ref = record_step(x_m, u0, u1, 0.001)
    rec, n = record_step(x_m, u0, u1, h)
    assert (n_ref, n) == (1000, round(1.0 / h))
    np.testing.assert_allclose(rec, ref, rtol=0, atol=1.5)
    fr, ft = fit_step(ref, 0.001, u1 - u0), fit_step(rec, 0.001, u1 - u0)
    np.testing.assert_allclose([ft.b, ft.c, ft.d], [fr.b, fr.c, fr.d], rtol=5e-3)
    assert ft.b > 0 and ft.c > 0 and ft.d > 0


def test_one_exchange_record_follows_the_pressure_path() -> None:
    """Inside one 1 s exchange the force moves at (nearly) every 1 ms sample: no staircase."""
    rec, _ = record_step(0.04, 1.0, 5.0, 1.0)
    assert np.count_nonzero(np.abs(np.diff(rec[:200])) > 1.0) > 100
