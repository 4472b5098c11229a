"""The profile that flags what the data do not fix (``fit.calibrate_profile``): against the
closed form of a linear model, and on the two ways a parameter escapes the data (a flat
direction, a curved valley of a product)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np
import pytest
from scipy.optimize import least_squares

from pam_bench.fit import calibrate_profile
from pam_bench.fit.calibrate_profile import (
    PROFILE_CHI2,
    PROFILE_FAR,
    PROFILE_MOVE,
    Profile,
    kept_profiles,
    profile,
    walk,
)

T = np.linspace(0.0, 1.0, 40)
NOISE = np.random.default_rng(3).normal(0.0, 0.01, T.size)
PRIOR = 1e-4


@dataclasses.dataclass(frozen=True)
class Toy:
    """A problem as the profile sees it: bounds and scaled data residuals at z."""

    model: Callable[[np.ndarray], np.ndarray]
    truth: np.ndarray
    lower: np.ndarray
    span: np.ndarray

    def data(self, z: np.ndarray) -> np.ndarray:
        theta = self.lower + z * self.span
        return self.model(theta) - (self.model(self.truth) + NOISE)


def fitted(toy: Toy) -> tuple[object, np.ndarray]:
    z0 = np.full(len(toy.truth), 0.5)

    def res(z: np.ndarray) -> np.ndarray:
        return np.concatenate([toy.data(z), PRIOR * (z - z0)])

    sol = least_squares(res, z0, bounds=(0.0, 1.0), xtol=1e-12, ftol=1e-12, gtol=1e-12)
    return sol, z0


def linear(theta: np.ndarray) -> np.ndarray:
    return theta[0] + theta[1] * T


def flat(theta: np.ndarray) -> np.ndarray:
    return theta[0] + theta[1] * T + 1e-7 * theta[2] * T ** 2


def product(theta: np.ndarray) -> np.ndarray:
    return theta[0] * theta[1] * T + theta[2] * T ** 2


def test_a_linear_models_rise_is_the_closed_form() -> None:
    toy = Toy(linear, np.array([0.05, 0.1]), np.zeros(2), np.array([2.0, 4.0]))
    sol, z0 = fitted(toy)
    names = ['a', 'b']
    out, better, _ = profile(toy, sol, z0, PRIOR, names, skip=[])
    jac = np.asarray(sol.jac)
    inv = np.linalg.inv(jac.T @ jac)
    data = np.asarray(sol.fun)[:-2]
    s2 = float(data @ data) / (len(data) - 2)
    theta = toy.lower + sol.x * toy.span
    for i, n in enumerate(names):
        dz = PROFILE_MOVE * theta[i] / toy.span[i]
        closed = dz ** 2 / inv[i, i] / s2                  # SSR rise of a linear model
        np.testing.assert_allclose([out[n].rise_low, out[n].rise_high], [closed, closed],
                                   rtol=1e-6)
        assert out[n].evaluations > 0
    assert better is None                                   # the fit is at its minimum


def test_a_flat_direction_is_flagged_with_its_range() -> None:
    toy = Toy(flat, np.array([1.0, 2.0, 3.0]), np.zeros(3), np.array([2.0, 4.0, 6.0]))
    sol, z0 = fitted(toy)
    out, better, _ = profile(toy, sol, z0, PRIOR, ['a', 'b', 'c'], skip=[])
    theta = toy.lower + sol.x * toy.span
    assert out['a'].fixed and out['b'].fixed
    assert not out['c'].fixed                               # c moves the data by 1e-7 T^2
    np.testing.assert_allclose([out['c'].low, out['c'].high],
                               theta[2] * np.array([1 - PROFILE_MOVE, 1 + PROFILE_MOVE]),
                               rtol=1e-9)
    assert 'not fixed by these recordings' in out['c'].line(theta[2])


def test_a_curved_valley_of_a_product_flags_both_factors_and_not_the_third() -> None:
    toy = Toy(product, np.array([2.0, 3.0, 1.0]), np.full(3, 0.5), np.full(3, 4.0))
    sol, z0 = fitted(toy)
    out, better, _ = profile(toy, sol, z0, PRIOR, ['a', 'b', 'c'], skip=[])
    assert not out['a'].fixed and not out['b'].fixed
    assert out['c'].fixed
    assert out['a'].evaluations >= 1                         # evaluated, not only predicted


def test_skipped_names_and_bounds_are_left_out() -> None:
    toy = Toy(flat, np.array([1.0, 2.0, 5.98]), np.zeros(3), np.array([2.0, 4.0, 6.0]))
    sol, z0 = fitted(toy)
    out, _, _ = profile(toy, sol, z0, PRIOR, ['a', 'b', 'c'], skip=['a'])
    assert set(out) == {'b', 'c'}
    theta_c = toy.lower[2] + sol.x[2] * toy.span[2]
    if theta_c * (1 + PROFILE_MOVE) > 6.0:                   # the bound ends that side
        assert out['c'].high == pytest.approx(6.0)


def test_a_fit_stopped_short_of_its_minimum_is_shown_the_lower_point() -> None:
    """A fit that ended away from its minimum (here: moved off it by hand): a move finds the
    cost lower by more than the noise and hands back where."""
    toy = Toy(linear, np.array([0.05, 0.1]), np.zeros(2), np.array([2.0, 4.0]))
    sol, z0 = fitted(toy)
    z_off = sol.x.copy()
    z_off[1] *= 1.4                                         # b 40 % off, a at the minimum
    r = np.concatenate([toy.data(z_off), PRIOR * (z_off - z0)])

    class Short:
        x, fun, jac = z_off, r, sol.jac
    _, better, _ = profile(toy, Short(), z0, PRIOR, ['a', 'b'], skip=[])
    assert better is not None
    lower = np.concatenate([toy.data(better), PRIOR * (better - z0)])
    assert float(lower @ lower) < float(r @ r)


T_LONG = np.linspace(0.0, 1.0, 2000)
NOISE_LONG = np.random.default_rng(5).normal(0.0, 0.01, T_LONG.size)


@dataclasses.dataclass(frozen=True)
class CurvedValley:
    """Many readings of a model whose cost has a narrow, curved valley (b = a^2) with a weak
    slope along it (its minimum near a = 1.3 with this noise and prior): a fit left far along
    the valley is many noise variances above the minimum, and a straight step leaves the floor.
    """

    lower: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(2))
    span: np.ndarray = dataclasses.field(default_factory=lambda: np.full(2, 4.0))

    @staticmethod
    def model(theta: np.ndarray) -> np.ndarray:
        return 20.0 * (theta[1] - theta[0] ** 2) * T_LONG + 0.018 * theta[0] * T_LONG ** 2

    def data(self, z: np.ndarray) -> np.ndarray:
        theta = self.lower + z * self.span
        return self.model(theta) - (self.model(np.ones(2)) + NOISE_LONG)


def test_the_walk_goes_down_a_curved_valley_the_profile_found() -> None:
    """A fit one step from a point 40 % along a curved valley (a at 1.4 times its minimum, b
    on the floor): the profile's lowest move (5 %, the other refitted by chord steps) is
    still tens of noise variances above the minimum; the walk makes that move again while
    the cost falls by more than ``PROFILE_CHI2`` and ends within it of the minimum, for at
    most ``PROFILE_STEPS`` evaluations a move and one to start."""
    toy = CurvedValley()
    z0 = np.full(2, 0.5)

    def res(z: np.ndarray) -> np.ndarray:
        return np.concatenate([toy.data(z), PRIOR * (z - z0)])

    def rise(z: np.ndarray) -> float:
        return (float(res(z) @ res(z)) - float(res(best.x) @ res(best.x))) / move.s2

    best = least_squares(res, z0, bounds=(0.0, 1.0), xtol=1e-12, ftol=1e-12, gtol=1e-12)
    a, b = toy.lower + best.x * toy.span
    theta_off = np.array([1.4 * a, (1.4 * a) ** 2 - a ** 2 + b])
    short = least_squares(res, (theta_off - toy.lower) / toy.span, bounds=(0.0, 1.0),
                          max_nfev=1)
    _, better, move = profile(toy, short, z0, PRIOR, ['a', 'b'], skip=[])
    assert better is not None and move is not None
    end, used = walk(move, better)
    assert rise(better) > 5 * PROFILE_CHI2
    assert rise(end) < PROFILE_CHI2
    assert used <= 1 + calibrate_profile.WALK_MOVES * calibrate_profile.PROFILE_STEPS


def exponentials(theta: np.ndarray) -> np.ndarray:
    return theta[1] * np.exp(theta[0] * T) + np.exp(theta[2] * T)


def test_a_parameter_fixed_by_far_stops_early_with_the_same_verdict(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The early stop spends fewer evaluations where the rises are far above the threshold,
    and ends where the full chord steps end to a percent, with the same verdicts."""
    toy = Toy(exponentials, np.array([2.0, 1.0, 0.5]), np.full(3, 0.1), np.full(3, 4.0))
    sol, z0 = fitted(toy)
    names = ['a', 'b', 'c']
    early, _, _ = profile(toy, sol, z0, PRIOR, names, skip=[])
    monkeypatch.setattr(calibrate_profile, 'PROFILE_FAR', np.inf)
    full, _, _ = profile(toy, sol, z0, PRIOR, names, skip=[])
    assert sum(p.evaluations for p in early.values()) < sum(
        p.evaluations for p in full.values())
    for n in names:
        assert early[n].fixed == full[n].fixed, n
        rises = [early[n].rise_low, early[n].rise_high]
        np.testing.assert_allclose(rises, [full[n].rise_low, full[n].rise_high], rtol=0.01)
        if early[n].evaluations < full[n].evaluations:          # stopped early: fixed by far
            assert min(rises) > PROFILE_FAR * PROFILE_CHI2, (n, rises)


@pytest.mark.parametrize('rises, fixed, moved, kept', [
    ((150.0, 300.0), True, 0.005, True),          # far on both sides, hardly moved
    ((150.0, math.nan), True, 0.005, True),       # a bound ended one side
    ((150.0, 300.0), True, 0.02, False),          # moved more than a fifth of the 5 %
    ((50.0, 300.0), True, 0.0, False),            # one side not far
    ((150.0, 300.0), False, 0.0, False),          # not fixed: moved again
])
def test_a_second_profile_keeps_only_what_was_fixed_by_far(
        rises: tuple[float, float], fixed: bool, moved: float, kept: bool) -> None:
    before = {'a': Profile('a', 0.95, 1.05, rises[0], rises[1], fixed, 7)}
    out = kept_profiles(before, np.array([1.0]), np.array([1.0 + moved]), ['a'])
    assert ('a' in out) == kept
    if kept:
        assert out['a'].evaluations == 0 and out['a'].rise_low == rises[0]


def test_a_kept_profile_is_not_moved_again() -> None:
    toy = Toy(exponentials, np.array([2.0, 1.0, 0.5]), np.full(3, 0.1), np.full(3, 4.0))
    sol, z0 = fitted(toy)
    first, _, _ = profile(toy, sol, z0, PRIOR, ['a', 'b', 'c'], skip=[])
    theta = toy.lower + sol.x * toy.span
    kept = kept_profiles(first, theta, theta, ['a', 'b', 'c'])
    assert set(kept) == {'b', 'c'}                            # a is free (rises about 2)
    again, _, _ = profile(toy, sol, z0, PRIOR, ['a', 'b', 'c'], skip=[], kept=kept)
    assert again['b'] == kept['b'] and again['c'] == kept['c']
    assert again['a'].evaluations == first['a'].evaluations
