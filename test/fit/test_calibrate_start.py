"""A bag calibration starts from the data, says whether it found the muscle, and holds by its
prior only what the data cannot fix (issue 42)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from pam_bench.fit.calibrate_bags import (
    FREE_BAGS,
    Observations,
    calibrate_bags,
    coarse,
    observations_from_twin,
    reached,
)
from pam_bench.fit.calibrate_verdict import FLOOR, NOISE_FACTOR, noise_levels, verdict
from pam_bench.models.muscle import MuscleParams
from pam_bench.models.sensors import LoadCellParams
from pam_bench.models.valve import ValveParams
from pam_bench.twin.protocol_run import run_protocol

# A muscle far from 004's: a smaller, stiffer one whose contact threshold lies below the
# grid's first non-zero voltage (0.2 V... it lies at 0.35 V: inside the grid, which crosses it),
# its valve a faster, better damped loop.
FAR_M = dataclasses.replace(
    MuscleParams(), gain_n_per_pa=2.2e-3, gain_min_n_per_pa=3.0e-4,
    gain_min_contraction_m=0.12, gain_exponent=2.4, threshold_pressure_pa=3.5e4,
    threshold_width_pa=1.5e4, bladder_stiffness_n_per_m=900.0,
    friction_stiffness_n_per_m=[k * 1.6 for k in MuscleParams().friction_stiffness_n_per_m])
FAR_V = dataclasses.replace(ValveParams(), natural_frequency_rad_s=120.0, damping_ratio=0.6)
TABLE = {
    'isometric_cross': {'kind': 'isometric', 'x_m': [0.0, 0.08, 0.04],
                        'voltage_v': [0.0, 6.0, 0.2], 'dwell_s': 3.0},
    'step_cross': {'kind': 'step_response', 'x_m': [0.0, 0.08, 0.04],
                   'up': {'u0_v': 1.0, 'step_v': 4.0, 'n': 1},
                   'down': {'u0_v': 5.0, 'step_v': -4.0, 'n': 1},
                   'dwell_s': 3.0, 'record_s': 1.0, 'sample_period_s': 0.001},
    'cross': {'kind': 'campaign', 'protocols': ['isometric_cross', 'step_cross']},
}
TRUE = {**dataclasses.asdict(FAR_M), **dataclasses.asdict(FAR_V),
        'friction_stiffness_scale': 1.6}


@pytest.fixture(scope='module')
def far_obs() -> Observations:
    """The far muscle's readings (noise on) on a grid that crosses its threshold."""
    run = run_protocol('cross', 3.0, table=TABLE, valve=FAR_V, muscle=FAR_M,
                       load_cell=LoadCellParams(noise=True), seed=7)
    assert run.exit_code == 0, run.reason
    return observations_from_twin(run.points, run.records)


def test_the_start_is_read_off_the_data(far_obs: Observations) -> None:
    from pam_bench.fit.calibrate_bags import _models
    from pam_bench.fit.calibrate_init import initial_values
    bounds = {n: (lo, hi) for _, n, lo, hi in FREE_BAGS}
    start = {n: 1.0 if n == 'friction_stiffness_scale' else
             getattr(ValveParams() if m == 'valve' else MuscleParams(), n)
             for m, n, _, _ in FREE_BAGS}

    def models(values: dict[str, float]) -> tuple[ValveParams, MuscleParams]:
        sub = tuple(f for f in FREE_BAGS if f[1] in values)
        return _models(np.array([values[f[1]] for f in sub]), ValveParams(), MuscleParams(),
                       sub)

    got, why = initial_values(far_obs.readings, far_obs.records, ValveParams(),
                              MuscleParams(), start, bounds, models)
    for name, rtol in (('gain_n_per_pa', 0.05), ('threshold_pressure_pa', 0.15),
                       ('threshold_width_pa', 0.3), ('bladder_stiffness_n_per_m', 0.1),
                       ('natural_frequency_rad_s', 0.1), ('damping_ratio', 0.1)):
        assert name in why, name
        np.testing.assert_allclose(got[name], TRUE[name], rtol=rtol, err_msg=name)
    # the defaults are far: the start gained on every one of them
    for name in ('gain_n_per_pa', 'threshold_pressure_pa', 'bladder_stiffness_n_per_m',
                 'natural_frequency_rad_s', 'damping_ratio'):
        assert abs(got[name] - TRUE[name]) < abs(start[name] - TRUE[name]), name


def test_a_far_muscle_converges_and_the_prior_holds_nothing_the_grid_fixes(
        far_obs: Observations) -> None:
    """The grid crosses the threshold: the threshold and its band are fixed by the data, not
    held at their starts by the prior: the threshold is not flagged, and both are recovered
    within 5 % from starts further off (the band's data-only variance sits just past the flag's
    line, ``UNFIXED_SHARE``: flagged or not, it is found); every parameter the data fix is
    within 5 %."""
    res = calibrate_bags(far_obs, max_nfev=40, starts=0)
    assert res['verdict']['converged'], res['verdict']
    for name in ('threshold_pressure_pa', 'gain_n_per_pa', 'bladder_stiffness_n_per_m',
                 'natural_frequency_rad_s', 'damping_ratio'):
        assert name not in res['flags'], (name, res['report'][name])
    for name in ('threshold_pressure_pa', 'threshold_width_pa'):
        np.testing.assert_allclose(res['values'][name], TRUE[name], rtol=0.05, err_msg=name)
        assert abs(res['start'][name] - TRUE[name]) > abs(res['values'][name] - TRUE[name])
    for name, value in res['values'].items():
        if name not in res['flags']:
            np.testing.assert_allclose(value, TRUE[name], rtol=0.05, err_msg=name)
    assert set(res['held']) == {'gain_rise_n_per_pa_m', 'stretch_stiffness_n_per_m'} - {
        n for n in ('gain_rise_n_per_pa_m',) if not reached(far_obs).get(n)}


def test_what_no_reading_shows_is_held() -> None:
    obs = Observations([('isometric', 1.0, 0.02, 100.0), ('isometric', 2.0, 0.04, 300.0)], [])
    assert set(reached(obs)) == {'gain_rise_n_per_pa_m', 'stretch_stiffness_n_per_m',
                                 'natural_frequency_rad_s', 'damping_ratio'}
    obs = Observations([('isotonic', 1.0, 500.0, -0.002), ('isometric', 2.0, 0.11, 30.0)],
                       [(0.0, 1.0, 5.0, 1e-3, np.zeros(100))])
    assert reached(obs) == {}


def test_a_large_bag_is_fitted_first_on_every_kth_series() -> None:
    readings = [('isometric', u, x, 0.0) for x in np.arange(10) * 0.01
                for u in np.arange(0.0, 6.01, 0.1)]
    obs = Observations(readings, [])
    small = coarse(obs, most=200)
    held = sorted({r[2] for r in small.readings})
    assert len(small.readings) <= 200 and np.allclose(held, [0.0, 0.04, 0.08])   # every 4th
    assert all(sum(r[2] == x for r in small.readings) == 61 for x in held)  # whole series
    assert coarse(obs, most=10_000) is obs


def test_noise_from_the_records_tails_and_repeated_readings() -> None:
    rng = np.random.default_rng(1)
    t = np.arange(1000)
    records = [(0.0, 1.0, 5.0, 1e-3, 300.0 * (1 - np.exp(-t / 30.0)) + rng.normal(0, 0.4, 1000))
               for _ in range(4)]
    readings = []
    for k in range(30):
        f = 100.0 + k
        readings += [('isometric', 6.0, 0.02 * k, f), ('isometric', 6.0, 0.02 * k,
                                                      f + rng.normal(0, 2.0))]
    noise = noise_levels(readings, records)
    np.testing.assert_allclose(noise['step_records'], 0.4, rtol=0.2)
    np.testing.assert_allclose(noise['isometric'], 2.0 / math.sqrt(2.0), rtol=0.35)
    assert noise_levels([('isotonic', 1.0, 100.0, 0.01)], [])['isotonic'] < 1e-3   # mm


@pytest.mark.parametrize('rms, converged', [(0.5, True), (0.61, False), (0.05, True)])
def test_the_verdict_is_the_noise_level(rms: float, converged: bool) -> None:
    v = verdict({'isometric': rms, 'step_records': 1.0}, {'isometric': 0.2,
                                                          'step_records': 0.2})
    assert v.tolerance == {'isometric': max(NOISE_FACTOR * 0.2, FLOOR['isometric']),
                           'step_records': FLOOR['step_records']}
    assert v.converged is converged
    assert v.line().startswith('converged' if converged else 'not converged')
    if not converged:
        assert v.above == ('isometric',) and 'try' in v.line()


def test_calibrate_with_a_law_of_the_zoo_recovers_it() -> None:
    """A bench whose muscle is Chou-Hannaford's law (001 Eq. 3) with its own parameters:
    ``calibrate --law chou_hannaford`` starts from the law fitted to the isometric readings,
    recovers the law and says converged (the static replay, fast; without step records the
    valve's loop is held at the bench's, so the readings are made with it)."""
    from pam_bench.config.settings import LawSettings
    from pam_bench.twin.quasistatic import QuasiStaticBench
    laws = LawSettings()
    laws = dataclasses.replace(laws, chou_hannaford=dataclasses.replace(
        laws.chou_hannaford, D0_m=0.018, theta0_rad=0.40))
    muscle = dataclasses.replace(MuscleParams(), kind='law', law='chou_hannaford')
    qs = QuasiStaticBench(ValveParams(), muscle, overshoot=True, laws=laws)
    readings = []
    for x in (0.0, 0.03, 0.06):
        for u in [*np.arange(0.0, 6.01, 0.5), *np.arange(6.0, -0.01, -0.5)]:
            readings.append(('isometric', float(u), x, qs.hold_position(float(u), x).force_n))
    res = calibrate_bags(Observations(readings, []), replay='static', law='chou_hannaford',
                         max_nfev=40)
    assert res['verdict']['converged'], res['verdict']
    np.testing.assert_allclose(res['values']['chou_hannaford.D0_m'], 0.018, rtol=0.01)
    np.testing.assert_allclose(res['values']['chou_hannaford.theta0_rad'], 0.40, rtol=0.01)
    assert res['muscle'].kind == 'law'
    assert res['laws'].chou_hannaford.D0_m == res['values']['chou_hannaford.D0_m']
    assert 'chou_hannaford' in res['law_zoo']


def test_a_law_with_wide_bounds_gets_steps_that_move_its_forces_a_percent() -> None:
    """002's law declares +-1e5 for every parameter: 1 % of that is 2000 N for b, a blind
    Jacobian. Each law parameter's step moves the forces by 1 % of their RMS (b and h enter
    linearly: the closed form), and never more than ``DIFF_STEP`` of its interval."""
    from pam_bench.fit.calibrate_bags import DIFF_STEP, LAW_FORCE_STEP, free_of_law, law_steps
    from pam_bench.models.laws.zoo import force_law
    law = force_law('sarosi')
    free = free_of_law(law)
    u = np.repeat(np.arange(0.0, 4.01, 0.5), 3)
    x = np.tile([0.0, 0.04, 0.08], len(u) // 3)
    readings = [('isometric', float(a), float(b), 0.0) for a, b in zip(u, x, strict=True)]
    theta = np.array([*law.start, *(0.5 * (lo + hi) for _, _, lo, hi in free[len(law.params):])])
    steps = law_steps(law, free, readings, theta, ValveParams().gain_pa_per_v, 0.35)
    th = np.array(law.start, float)
    p, k = ValveParams().gain_pa_per_v * u / 1e5, x / 0.35
    rms = float(np.sqrt(np.mean(law.law(th, p * 1e5, x, 0.35) ** 2)))
    a, b, c, d, e, f, g, h = th
    slopes = {'b': np.exp(c * k + d), 'h': np.ones_like(k), 'f': k}
    for n, slope in slopes.items():
        i = law.params.index(n)
        want = LAW_FORCE_STEP * rms / float(np.sqrt(np.mean(slope ** 2))) / 2e5
        np.testing.assert_allclose(steps[i], want, rtol=1e-4)
    assert np.all(steps <= DIFF_STEP) and steps[law.params.index('b')] < 0.01 * DIFF_STEP
    assert np.all(steps[len(law.params):] == DIFF_STEP)          # the valve, the friction


def test_a_law_with_wide_bounds_is_fitted_to_the_noise_level() -> None:
    """The zoo study's false 'not converged' (002's law, seed 1: 0.97 N against a noise level
    of 0.6 N, the fit ended where its static start was, at 35 times the truth's cost): with the
    steps scaled to the forces it reaches the noise level, and every parameter the data leave
    free (002's eight are not all fixed by three positions) is flagged, none reported fixed
    more than 5 % off."""
    from pam_bench.models.laws.zoo import force_law
    run = run_protocol('isometric_quick', 3.0, overrides={'voltage_v': [0.0, 4.0, 0.5]},
                       muscle=MuscleParams(kind='law', law='sarosi'), sub_step_s=0.005,
                       load_cell=LoadCellParams(noise=True), seed=1)
    res = calibrate_bags(observations_from_twin(run.points, run.records), law='sarosi')
    assert res['verdict']['converged'], res['verdict']
    law = force_law('sarosi')
    for n, truth in zip(law.params, law.start, strict=True):
        name = f'sarosi.{n}'
        if name not in res['flags'] and truth:
            assert abs(res['values'][name] / truth - 1.0) < 0.05, (name, res['values'][name])


def test_bags_that_declare_a_law_are_fitted_as_that_law_without_naming_it() -> None:
    """A bag recorded with a law muscle, calibrated without ``--law``: its own law is fitted
    (the McKibben parameters would move nothing, and a fit of none of them said 'converged'
    with every parameter flagged)."""
    muscle = dataclasses.replace(MuscleParams(), kind='law', law='chou_hannaford')
    readings = [('isometric', 2.0, 0.0, 300.0), ('isometric', 4.0, 0.0, 700.0),
                ('isometric', 2.0, 0.04, 150.0), ('isometric', 4.0, 0.04, 400.0)]
    res = calibrate_bags(Observations(readings, []), muscle=muscle, replay='static',
                         max_nfev=2, starts=0)
    assert res['law'] == 'chou_hannaford'
    assert 'chou_hannaford.D0_m' in res['values'] and 'gain_n_per_pa' not in res['values']


def test_a_fit_that_stopped_short_goes_on_to_recover_a_weak_friction() -> None:
    """The braid friction at the low end of its range (scale 0.2) moves the readings little:
    the fit reaches the noise level early, short of the optimum; its Gauss-Newton step shows
    it, and the fit goes on until the friction is recovered within 5 % (it stopped 10.6 % off
    before, unflagged: BENCHMARKS.md, "Calibrating the bench to recordings, across the
    bounds")."""
    from benchmarks import calibrate_bounds as cb
    from pam_bench.config.protocols import load_protocols
    from pam_bench.fit.calibrate_bags import calibrate_bags, observations_from_twin
    from pam_bench.models.sensors import LoadCellParams
    from pam_bench.twin.protocol_run import run_protocol
    k = next(i for i in range(2 * len(cb.FREE_BAGS))
             if cb._end_label(i).startswith('friction_stiffness_scale at its lower end'))
    values = cb.end_set(k)
    valve, muscle = cb._apply(values)
    run = run_protocol(cb.PROTOCOL, 3.0, table=load_protocols(), valve=valve, muscle=muscle,
                       load_cell=LoadCellParams(noise=True), seed=100 + k)
    res = calibrate_bags(observations_from_twin(run.points, run.records))
    assert res['verdict']['converged']
    true = values['friction_stiffness_scale']
    assert 'friction_stiffness_scale' not in res['flags']
    assert abs(res['values']['friction_stiffness_scale'] - true) <= 0.05 * true, res['values']


def test_a_gain_rise_past_the_stability_rule_is_clamped_not_refused() -> None:
    """A trial past g_r 1 MPa < k_bl (``models.muscle``) builds a muscle just inside the rule:
    the fit reads a flat slope there, not a refused model."""
    from pam_bench.fit.calibrate_bags import RISE_MARGIN, Bench, _bench
    from pam_bench.models.muscle import MAX_PRESSURE_PA, MuscleModel
    free = tuple(f for f in FREE_BAGS if f[1] in ('gain_rise_n_per_pa_m',
                                                  'bladder_stiffness_n_per_m'))
    for rise, kbl in ((9.0e-4, 400.0), (1.0e-4, 400.0)):
        bench = _bench(np.array([rise, kbl]), Bench(ValveParams(), MuscleParams()), free)
        most = RISE_MARGIN * kbl / MAX_PRESSURE_PA
        np.testing.assert_allclose(bench.muscle.gain_rise_n_per_pa_m, min(rise, most),
                                   rtol=1e-12)
        MuscleModel(bench.muscle)                       # a valid muscle: no ModelError
