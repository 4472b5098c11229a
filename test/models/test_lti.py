"""Exact ZOH against closed forms, in every damping regime (no sqrt(b^2 - 4c) anywhere)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pam_bench.models.lti import second_order_matrices, zoh


def step_response(b: float, c: float, d: float, t: float) -> float:
    """y(t) of y'' + b y' + c y = d (unit step), y(0) = y'(0) = 0, per regime."""
    y_ss = d / c
    disc = b * b - 4.0 * c
    if disc < 0:
        w = math.sqrt(-disc) / 2.0
        s = -b / 2.0
        return y_ss * (1 - math.exp(s * t) * (math.cos(w * t) - s / w * math.sin(w * t)))
    if disc == 0:
        s = -b / 2.0
        return y_ss * (1 - math.exp(s * t) * (1 - s * t))
    r1 = (-b + math.sqrt(disc)) / 2.0
    r2 = (-b - math.sqrt(disc)) / 2.0
    return y_ss * (1 + (r2 * math.exp(r1 * t) - r1 * math.exp(r2 * t)) / (r1 - r2))


@pytest.mark.parametrize('b, c', [
    (6.0, 25.0),          # underdamped
    (10.0, 25.0),         # critically damped, b^2 = 4c exactly
    (26.0, 25.0),         # overdamped
    (0.02, 1.0e4),        # very underdamped
    (2.0e3, 1.0),         # very overdamped (stiff)
])
def test_zoh_matches_closed_form(b: float, c: float) -> None:
    a, bm = second_order_matrices(b, c, c)
    h = 1e-3
    ad, bd = zoh(a, bm, h)
    x = np.zeros(2)
    for k in range(1, 501):
        x = ad @ x + bd[:, 0]
        if k % 50 == 0:
            np.testing.assert_allclose(x[0], step_response(b, c, c, k * h), rtol=1e-10,
                                       atol=1e-12)


@pytest.mark.parametrize('eps', [0.0, 1e-12, -1e-12])
def test_zoh_near_critical_is_continuous(eps: float) -> None:
    b, c = 10.0, 25.0 * (1 + eps)
    a, bm = second_order_matrices(b, c, c)
    ad, bd = zoh(a, bm, 0.5)
    ref = step_response(10.0, 25.0, 25.0, 0.5)
    assert np.all(np.isfinite(ad)) and np.all(np.isfinite(bd))
    np.testing.assert_allclose(bd[0, 0], ref, rtol=1e-9)


@pytest.mark.parametrize('zeta', [0.0, 0.05, 0.5, 1.0, 1.2, 3.0, 50.0])
@pytest.mark.parametrize('w, h', [(30.0, 1e-3), (150.0, 1e-4), (150.0, 1e-3), (150.0, 0.5),
                                  (900.0, 1e-5), (900.0, 1e-2)])
def test_two_state_closed_form_matches_expm(zeta: float, w: float, h: float) -> None:
    """The 2x2 closed form (module docstring of models.lti) against the Van Loan exponential,
    from lightly damped to stiff, short steps (Ad - I without cancellation) to long ones."""
    from scipy.linalg import expm

    from pam_bench.models.lti import _zoh_2x2
    a, bm = second_order_matrices(2.0 * zeta * w, w * w, w * w)
    fast = _zoh_2x2(a, bm, h)
    assert fast is not None                      # every case here takes the closed form
    blk = np.zeros((3, 3))
    blk[:2, :2], blk[:2, 2:] = a, bm
    e = expm(blk * h)
    np.testing.assert_allclose(fast[0], e[:2, :2], rtol=1e-11, atol=1e-13)
    np.testing.assert_allclose(fast[1], e[:2, 2:], rtol=1e-11, atol=1e-13 * np.abs(e).max())


def test_nearly_singular_two_state_system_falls_back_to_expm() -> None:
    """A first-order loop written with two states (a zero row) has det A = 0: the closed form
    declines and ``zoh`` still returns the exact update."""
    from pam_bench.models.lti import _zoh_2x2
    a = np.array([[-1.0 / 0.02, 0.0], [0.0, 0.0]])
    bm = np.array([[1.0 / 0.02], [0.0]])
    assert _zoh_2x2(a, bm, 1e-2) is None                  # ||A|| h = 0.5: past the series
    ad, bd = zoh(a, bm, 1e-2)
    np.testing.assert_allclose(ad[0, 0], math.exp(-0.5), rtol=1e-14)
    np.testing.assert_allclose(bd[0, 0], -math.expm1(-0.5), rtol=1e-14)


@pytest.mark.parametrize('a, bm, h', [
    (np.array([[-1.0 / 0.02, 0.0], [0.0, 0.0]]), np.array([[1.0 / 0.02], [0.0]]), 1e-3),
    (*second_order_matrices(11.26, 352.05, 352.05), 1e-9),      # the 1 ns flush tick
    (*second_order_matrices(2.0 * 0.3 * 300.0, 300.0**2, 300.0**2), 1e-6),
    (*second_order_matrices(0.0, 0.0, 1.0), 0.05),              # a double integrator
])
def test_a_short_step_of_a_nearly_singular_system_sums_the_series(a: np.ndarray,
                                                                  bm: np.ndarray,
                                                                  h: float) -> None:
    """Where the closed form declines and ||A|| h <= 0.1, the series path gives the exact
    update to the last bits, without a LAPACK call (``lti._series_2x2``), against expm."""
    from scipy.linalg import expm

    from pam_bench.models.lti import _zoh_2x2
    fast = _zoh_2x2(a, bm, h)
    assert fast is not None
    blk = np.zeros((3, 3))
    blk[:2, :2], blk[:2, 2:] = a, bm
    e = expm(blk * h)
    np.testing.assert_allclose(fast[0], e[:2, :2], rtol=1e-14, atol=1e-300)
    np.testing.assert_allclose(fast[1], e[:2, 2:], rtol=1e-13, atol=1e-30)


@pytest.mark.parametrize('a, bm', [
    (second_order_matrices(2.0 * 0.7 * 150.0, 150.0**2, 150.0**2)),     # the valve's loop
    (np.array([[-1.0 / 0.02, 0.0], [0.0, 0.0]]), np.array([[1.0 / 0.02], [0.0]])),  # expm
])
def test_zoh_cache_in_floats_gives_the_arrays_and_shares_their_store(a: np.ndarray,
                                                                      bm: np.ndarray) -> None:
    """``ZohCache.get_2x2`` gives exactly ``zoh``'s entries (closed form or expm fallback),
    and ``get`` finds what ``get_2x2`` stored under the same key: a valve that steps one way
    and samples the other reuses one computation, as it did with arrays alone."""
    from pam_bench.models.lti import ZohCache
    ad, bd = zoh(a, bm, 1e-3)
    cache = ZohCache()
    entries = (*(float(v) for v in a.ravel()), float(bm[0, 0]), float(bm[1, 0]))
    got = cache.get_2x2(('v', 1.0), *entries, 1e-3)
    assert got == (ad[0, 0], ad[0, 1], ad[1, 0], ad[1, 1], bd[0, 0], bd[1, 0])
    other = a * (1.0 + 1e-12)          # a system the key calls the same: the stored result
    ad2, bd2 = cache.get(('v', 1.0), other, bm, 1e-3)
    assert ad2.tolist() == ad.tolist() and bd2.tolist() == bd.tolist()
