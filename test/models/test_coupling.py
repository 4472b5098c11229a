"""The muscle and its holder solved per sub-step: the root is found on hard cases, the
sub-step grid, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pam_bench.models.coupling import (
    MAX_ITERATIONS,
    solve_substep,
    solve_substeps,
    substep_grid,
)
from pam_bench.models.errors import ModelError
from pam_bench.models.loading_servo import (
    IdealHold,
    LoadingServoModel,
    LoadingServoParams,
    LoadMode,
)
from pam_bench.models.muscle import MuscleModel


def _drive(mode: LoadMode, setpoint: float, x0: float, **kw: float) -> LoadingServoModel:
    d = LoadingServoModel(LoadingServoParams(**kw))
    d.reset(x0)
    d.command(mode, setpoint)
    return d


CASES = {
    # name: (holder, pressures Pa over the run, muscle mounted at x m)
    'slack muscle, force mode': (lambda: _drive(LoadMode.FORCE, 300.0, 0.05), [0.0] * 400,
                                 0.05),
    'vented while held at 50 N': (lambda: _drive(LoadMode.FORCE, 50.0, 0.107),
                                  [6e5] * 200 + [0.0] * 800, 0.107),
    'stretched against the braid lock-up, drive saturates': (
        lambda: _drive(LoadMode.POSITION, -0.005, -0.005), [6e5] * 600, -0.005),
    'end stop at full contraction': (lambda: _drive(LoadMode.OFF, 0.0, 0.15), [6e5] * 400,
                                     0.15),
    'friction stick-slip in force mode': (
        lambda: _drive(LoadMode.FORCE, 400.0, 0.03),
        list(3e5 + 1e5 * np.sin(np.linspace(0.0, 12.0, 1000))), 0.03),
    'ideal hold': (lambda: IdealHold(0.04, 2e6), list(np.linspace(0.0, 6e5, 300)), 0.04),
    'ideal force source': (lambda: _drive(LoadMode.FORCE, 200.0, 0.02, dynamics=False),
                           [3e5] * 300, 0.02),
}


@pytest.mark.parametrize('name', list(CASES))
@pytest.mark.parametrize('d', [1e-4, 5e-3, 0.1])
def test_every_sub_step_is_a_root(name: str, d: float) -> None:
    """At every sub-step the force is the muscle's own force at the holder's position for it
    (to the solver's tolerance), never negative, finite, within the iteration limit."""
    make, pressures, x0 = CASES[name]
    holder, muscle = make(), MuscleModel()
    muscle.reset(x0, 0.0)
    f = 0.0
    for p in pressures:
        f, x, k, ff, it = solve_substep(muscle, holder, d, p, f)
        assert math.isfinite(f) and math.isfinite(x) and f >= 0.0
        assert it <= MAX_ITERATIONS
        # the friction kept is that of the root: evaluating there again moves nothing
        assert abs(muscle.trial(p, x)[0] - f) <= 1e-6 * max(1.0, f)


def test_newton_needs_few_iterations_on_a_protocol_like_run() -> None:
    drive = _drive(LoadMode.FORCE, 500.0, 0.0)
    muscle = MuscleModel()
    steps = [0.005] * 600
    res = solve_substeps(muscle, drive, steps, [2e5] * 600, 0.0)
    assert res.iterations / len(steps) < 4.0


@pytest.mark.parametrize('guess', [0.0, 50.0, 500.0, 5000.0])
def test_a_slack_muscle_is_found_without_bisection(guess: float) -> None:
    """Vented, the muscle pulls with nothing: whatever the guess, the solve tries the force at
    X(0) after at most one Newton step instead of halving the bracket down to 0 N."""
    drive, muscle = _drive(LoadMode.FORCE, 50.0, 0.107), MuscleModel()
    muscle.reset(0.107, 0.0)
    f, _, _, _, it = solve_substep(muscle, drive, 0.005, 0.0, guess)
    assert f == 0.0
    assert it <= 2


def test_drive_end_follows_a_changed_state() -> None:
    """The drive keeps its last sub-step end per force; a state set from outside (a restored
    snapshot) between two asks for the same force must not return the kept one."""
    drive = _drive(LoadMode.FORCE, 100.0, 0.02)
    drive.prepare(0.005)
    x1 = drive.contraction(100.0)
    assert drive.contraction(100.0) == x1
    drive.phi += 0.01
    np.testing.assert_allclose(drive.contraction(100.0) - x1, drive.r * 0.01, rtol=1e-9)


@pytest.mark.parametrize('dt, period, expected', [
    (3.0, 0.005, [0.005] * 600), (0.0123, 0.005, [0.005, 0.005, 0.0023]),
    (0.001, 0.005, [0.001]), (1.0, 0.001, [0.001] * 1000)])
def test_substep_grid(dt: float, period: float, expected: list[float]) -> None:
    got = substep_grid(dt, min(period, dt))
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(sum(got), dt, rtol=0, atol=1e-9)


def test_bad_input_raises() -> None:
    with pytest.raises(ModelError):
        solve_substep(MuscleModel(), IdealHold(0.0, 2e6), 0.001, math.nan, 0.0)
    with pytest.raises(ModelError):
        solve_substeps(MuscleModel(), IdealHold(0.0, 2e6), [0.001, 0.001], [1e5], 0.0)
    with pytest.raises(ModelError):
        substep_grid(0.0, 0.001)


@pytest.mark.parametrize('mode, setpoint', [(LoadMode.FORCE, 300.0), (LoadMode.POSITION, 0.04),
                                            (LoadMode.OFF, 0.0)])
@pytest.mark.parametrize('force', [0.5, 50.0, 400.0, 3000.0])
def test_drive_compliance_is_the_slope_of_its_contraction(mode: LoadMode, setpoint: float,
                                                          force: float) -> None:
    """dX/dF the Newton step uses equals the finite difference of X(F) on the piece the force
    falls on (central, 1e-4 N), and the pair comes from one evaluation."""
    drive = _drive(mode, setpoint, 0.04)
    drive.prepare(0.005)
    x, c = drive.contraction_and_compliance(force)
    assert x == drive.contraction(force)
    h = 1e-4
    slope = (drive.contraction(force + h) - drive.contraction(force - h)) / (2 * h)
    np.testing.assert_allclose(c, slope, rtol=1e-5, atol=1e-12)
