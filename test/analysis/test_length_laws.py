"""003's length law against its own Table 6, its stiffness law against Eq. 12."""

from __future__ import annotations

import numpy as np
import pytest

from pam_bench.analysis.force_models import FORCE_MODELS
from pam_bench.analysis.length_laws import (
    al_ibadi_length,
    al_ibadi_stiffness,
    max_contraction_ratio,
)


@pytest.mark.parametrize('d0_m, s_r, ratio', [
    (0.0152, 363.33, 0.29),      # A (Table 5) -> 29 % (Table 6)
    (0.0174, 1090.0, 0.195),     # B -> 19.5 %
    (0.0297, 545.0, 0.243),      # C -> 24.3 %
])
def test_largest_contraction_matches_table_6(d0_m: float, s_r: float, ratio: float) -> None:
    np.testing.assert_allclose(max_contraction_ratio(d0_m, s_r), ratio, atol=0.015)


def test_length_law_shape() -> None:
    p = np.array([0.0, 1e5, 1e12])
    length = al_ibadi_length(p, 0.2, 0.0152, 363.33)
    assert np.all(np.diff(length) <= 0.0)                      # shortens with pressure
    np.testing.assert_allclose(length[-1], 0.2 * (1 - max_contraction_ratio(0.0152, 363.33)),
                               rtol=1e-9)


def test_stiffness_is_force_over_contraction() -> None:
    """Eq. 19 is Eq. 12 divided by dL."""
    law = next(m for m in FORCE_MODELS if m.name == 'al_ibadi').law
    th = np.array([0.02, 0.4, 1e-3, 200.0])
    p, x = np.array([2e5, 4e5]), np.array([0.01, 0.04])
    np.testing.assert_allclose(al_ibadi_stiffness(p, x, 0.35, 0.02, 0.4, 1e-3, 200.0),
                               law(th, p, x, 0.35) / x, rtol=1e-12)
