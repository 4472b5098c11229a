"""Al-Ibadi's laws (003): the force with the secant as printed, the length law against its own
Table 6, the stiffness law against Eq. 12."""

from __future__ import annotations

import numpy as np
import pytest

from pam_bench.models.laws import al_ibadi
from pam_bench.models.laws.al_ibadi import WORK_LOSS_NM, max_contraction_ratio


@pytest.mark.parametrize('d0_m, s_r, ratio', [
    (0.0152, 363.33, 0.29),      # A (Table 5) -> 29 % (Table 6)
    (0.0174, 1090.0, 0.195),     # B -> 19.5 %
    (0.0297, 545.0, 0.243),      # C -> 24.3 %
])
def test_largest_contraction_matches_table_6(d0_m: float, s_r: float, ratio: float) -> None:
    np.testing.assert_allclose(max_contraction_ratio(d0_m, s_r), ratio, atol=0.015)


def test_length_law_shape() -> None:
    p = np.array([0.0, 1e5, 1e12])
    length = al_ibadi.length(p, 0.2, 0.0152, 363.33)
    assert np.all(np.diff(length) <= 0.0)                      # shortens with pressure
    np.testing.assert_allclose(length[-1], 0.2 * (1 - max_contraction_ratio(0.0152, 363.33)),
                               rtol=1e-9)


def test_stiffness_is_force_over_contraction() -> None:
    """Eq. 19 is Eq. 12 divided by dL."""
    law = al_ibadi.force
    th = np.array([0.02, 0.4, 1e-3, 200.0])
    p, x = np.array([2e5, 4e5]), np.array([0.01, 0.04])
    np.testing.assert_allclose(al_ibadi.stiffness(p, x, 0.35, 0.02, 0.4, 1e-3, 200.0),
                               law(th, p, x, 0.35) / x, rtol=1e-12)


@pytest.mark.parametrize('x_m', [0.01, 0.03, 0.06])
def test_al_ibadi_uses_the_secant_from_the_initial_state(x_m: float) -> None:
    """003 Eq. 12: F = p (V(L) - V(l0)) / (l0 - L) - (s_r A_in + 0.641) / (l0 - L), the
    volume change counted from the rest length, not the tangent at L."""
    al_ibadi_volume = al_ibadi.volume
    d0, t0, th, s_r, l0, p = 0.02, 0.40, 1e-3, 200.0, 0.35, 3e5
    v = al_ibadi_volume(np.array([l0 - x_m, l0]), d0, t0, th, l0)
    b = l0 / np.cos(t0)                                   # closed form of D(l0): D0
    assert np.sqrt(b ** 2 - l0 ** 2) / (b * np.sin(t0) / d0) == pytest.approx(d0, rel=1e-12)
    a_in = np.pi * (d0 - th) ** 2 / 4
    want = p * (v[0] - v[1]) / x_m - (s_r * a_in + WORK_LOSS_NM) / x_m
    got = al_ibadi.force(np.array([d0, t0, th, s_r]), np.array([p]), np.array([x_m]), l0)
    np.testing.assert_allclose(got, [want], rtol=1e-12)
    # the secant differs from the tangent at L by a finite amount at a finite contraction
    h = 1e-7
    dv_dl = (al_ibadi_volume(np.array([l0 - x_m + h]), d0, t0, th, l0)
             - al_ibadi_volume(np.array([l0 - x_m - h]), d0, t0, th, l0)) / (2 * h)
    tangent = -p * dv_dl[0] - (s_r * a_in + WORK_LOSS_NM) / x_m
    assert abs(got[0] - tangent) > 1e-3 * abs(tangent)


@pytest.mark.parametrize('l0_m', [0.15, 0.2, 0.3, 0.4])
def test_eq14_starts_at_the_free_length_and_shortens_with_pressure(l0_m: float) -> None:
    a, b, c, _, _ = al_ibadi.eq14_coefficients(l0_m)
    np.testing.assert_allclose(a + b, l0_m, rtol=1e-12)
    assert c < 0.0                     # as printed: why |c| is used (module docstring)
    length = al_ibadi.length_eq14(np.linspace(0.0, 5e5, 11), l0_m)
    np.testing.assert_allclose(length[0], l0_m, rtol=1e-12)
    assert np.all(np.diff(length) < 0.0)


@pytest.mark.parametrize('l0_m, ratio', [(0.2, 0.29), (0.3, 0.286)])   # Table 6: A and D
def test_eq14_at_5_bar_against_table_6(l0_m: float, ratio: float) -> None:
    got = 1 - al_ibadi.length_eq14(np.array([5e5]), l0_m)[0] / l0_m
    np.testing.assert_allclose(got, ratio, atol=0.025)   # D: 30.6 % against 28.6 %
