"""Inverse models: the dynamic inverse undoes 004 Eq. 2, the static one the isometric line."""

from __future__ import annotations

import numpy as np
import pytest

from pam_bench.control.inverse import InverseModel, Poly
from pam_bench.models.errors import ModelError


def const(v: float) -> Poly:
    return Poly((v,), 0.04, 0.04)


def model() -> InverseModel:
    # b, c, d constant; F_a0 and k linear in x over 0..80 mm
    return InverseModel(const(18.0), const(900.0), const(2.5e5), Poly((150.0, -100.0), 0.04, 0.04),
                        1.0, Poly((150.0, -120.0), 0.04, 0.04), const(-40.0), 0.0, 6.0)


@pytest.mark.parametrize('x_m', [0.0, 0.02, 0.08])
def test_dynamic_inverse_matches_forward_model(x_m: float) -> None:
    m = model()
    f, df, ddf = 400.0, 30.0, -5.0
    u = m.dynamic_voltage(f, df, ddf, x_m)
    # forward: F'' + b F' + c (F - F_a0) = d (u - u0)
    lhs = ddf + 18.0 * df + 900.0 * (f - m.f_a0(x_m))
    np.testing.assert_allclose(lhs, 2.5e5 * (u - 1.0), rtol=1e-12)


def test_static_inverse_and_clamps() -> None:
    m = model()
    x = 0.04
    k = m.k(x)
    np.testing.assert_allclose(m.static_voltage(k * 2.0 - 40.0, x), 2.0, rtol=1e-12)
    assert m.static_voltage(1e6, x) == 6.0 and m.static_voltage(-1e6, x) == 0.0
    # x is clamped to the identified range: no extrapolation beyond 80 mm
    assert m.k(0.2) == pytest.approx(m.k(0.08))


def test_malformed_file(tmp_path) -> None:
    (tmp_path / 'inv.yaml').write_text('dynamic: {}\n')
    with pytest.raises(ModelError, match='missing or malformed'):
        InverseModel.load(tmp_path / 'inv.yaml')


def test_forward_force_is_the_inverse_run_backwards() -> None:
    """Drive the forward model (004 Eq. 4) with the dynamic inverse's voltage for a smooth
    F*(t): once the start (at rest, F*' = 50 N/s) has died out it returns F*(t) (a 1 ms hold:
    within 0.5 N of a 50 N swing), and a held step settles at F_a0 + d / c (u - u0)."""
    m = model()
    h, x = 0.001, 0.02
    t = np.arange(0.0, 6.0, h)
    f = 400.0 + 50.0 * np.sin(t)
    u = np.array([m.dynamic_voltage(fi, 50 * np.cos(ti), -50 * np.sin(ti), x)
                  for fi, ti in zip(f, t, strict=True)])
    got = m.forward_force(u, h, x, float(f[0]))
    np.testing.assert_allclose(got[t >= 1.0], f[t >= 1.0], atol=0.5)
    step = m.forward_force(np.full(5000, m.u0_v + 1.0), h, x, m.f_a0(x))
    np.testing.assert_allclose(step[-1], m.f_a0(x) + m.d(x) / m.c(x), rtol=1e-6)


@pytest.mark.parametrize('degree', [0, 1, 2, 3, 5])
def test_poly_is_numpy_polyval_bit_for_bit(degree: int) -> None:
    """Horner in floats gives numpy's ``polyval`` bits, inside and at the clamped ends."""
    rng = np.random.default_rng(degree)
    for _ in range(200):
        coef = tuple(float(v) for v in rng.normal(0.0, 1e3, degree + 1))
        p = Poly(coef, 0.04, 0.035)
        x = float(rng.uniform(-0.02, 0.1))
        z = min(max((x - 0.04) / 0.035, -1.0), 1.0)
        assert p(x) == float(np.polynomial.polynomial.polyval(z, coef))
    assert Poly((1.0, 2.0), 0.04, 0.0)(0.5) == 1.0            # no range: z = 0
