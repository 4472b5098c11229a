"""pam-bench calibrate --target 004: the fit moves a mis-set muscle towards 004's figures; the
overlay it writes loads into a scene."""

from __future__ import annotations

import dataclasses
import pathlib

import numpy as np
import pytest

from pam_bench.config.errors import ConfigError
from pam_bench.config.scene import apply_overlay, load_scene
from pam_bench.fit.calibrate import FREE, calibrate_004, residuals_004
from pam_bench.models.errors import ModelError
from pam_bench.models.muscle import MuscleParams
from pam_bench.verify.figures_004 import measure_004


def test_defaults_are_at_the_fit() -> None:
    """The defaults are the fit's optimum: a nudge of any free parameter costs more."""
    base = MuscleParams()
    cost0 = float(np.sum(residuals_004(measure_004(muscle=base)) ** 2))
    for name, _, _ in FREE:
        if name == 'friction_stiffness_scale':
            continue
        worse = dataclasses.replace(base, **{name: getattr(base, name) * 1.1})
        try:
            cost = float(np.sum(residuals_004(measure_004(muscle=worse)) ** 2))
        except ModelError:          # a nudge that breaks a model bound counts as worse
            continue
        assert cost > cost0, name


def test_a_step_from_a_mis_set_muscle_does_not_raise_the_cost() -> None:
    """One trust-region step (the full fit takes minutes: BENCHMARKS.md, 'Calibration
    against 004'); its summary names every free parameter."""
    base = dataclasses.replace(MuscleParams(), gain_n_per_pa=3.4e-3,
                               threshold_pressure_pa=1.0e5)
    cost0 = float(np.sum(residuals_004(measure_004(muscle=base)) ** 2)) / 2
    res = calibrate_004(base, max_nfev=1)
    assert res['cost'] <= cost0
    assert set(res['stderr']) == {n for n, _, _ in FREE}
    assert len(res['correlation']) == len(FREE)


def test_overlay_goes_over_bench_yaml_and_under_the_scene(tmp_path: pathlib.Path) -> None:
    path = tmp_path / 'overlay.yaml'
    path.write_text('parameters:\n  muscle_1: {muscle: {gain_n_per_pa: 0.003, hysteresis: true}}\n'
                    '  muscle_2: {muscle: {gain_n_per_pa: 0.003}}\n')
    scene = load_scene('isometric_quick')
    scene.parameters.setdefault('muscle_1', {})['muscle'] = {'hysteresis': False}
    apply_overlay(scene, path)
    muscle = scene.parameters['muscle_1']['muscle']
    assert muscle == {'gain_n_per_pa': 0.003, 'hysteresis': False}
    assert 'muscle_2' not in scene.parameters                  # not in this scene


@pytest.mark.parametrize('text, words', [
    ('parameters:\n  muscle_1: {muscle: {gain_n_per_paa: 0.003}}\n', 'did you mean'),
    ('paramters: {}\n', "'paramters'"),
    ('parameters:\n  musle_1: {}\n', "'musle_1'"),
])
def test_a_bad_overlay_is_one_clear_error(tmp_path: pathlib.Path, text: str,
                                          words: str) -> None:
    path = tmp_path / 'overlay.yaml'
    path.write_text(text)
    with pytest.raises(ConfigError, match=words):
        apply_overlay(load_scene('isometric_quick'), path)


def _exact_observations(valve, muscle):
    """campaign_quick's readings and records with the values the quasi-static bench gives
    for (valve, muscle): the model the fit uses, so the round trip must be exact."""
    from pam_bench.config.protocols import protocol_schedule
    from pam_bench.fit.calibrate_bags import Bench, Observations, predict
    readings, recs = [], []
    for r in protocol_schedule('campaign_quick', {})[0]:
        if r.record_s > 0.0:
            recs.append((r.load_value, r.pre_voltage_v, r.voltage_v, r.sample_period_s,
                         np.zeros(int(round(r.record_s / r.sample_period_s)))))
        elif r.recorded:
            kind = r.protocol.split('_')[0]
            readings.append((kind, r.voltage_v, r.load_value, 0.0))
    obs = Observations(readings, recs)
    values, model = predict(obs, Bench(valve, muscle), replay='static')
    obs.readings = [(k, u, h, float(v)) for (k, u, h, _), v in zip(readings, values,
                                                                    strict=True)]
    for i, (x, u0, u1, period, samples) in enumerate(recs):
        full = np.repeat(model[i], 10)[:len(samples)]
        obs.records[i] = (x, u0, u1, period, full)
    return obs


def test_bag_calibration_recovers_a_known_bench() -> None:
    from pam_bench.fit.calibrate_bags import calibrate_bags
    from pam_bench.models.valve import ValveParams
    true_m = dataclasses.replace(MuscleParams(), gain_n_per_pa=3.4e-3,
                                 threshold_pressure_pa=7.5e4)
    true_v = dataclasses.replace(ValveParams(), damping_ratio=0.4)
    obs = _exact_observations(true_v, true_m)
    res = calibrate_bags(obs, max_nfev=20,
                         only=('gain_n_per_pa', 'threshold_pressure_pa', 'damping_ratio'),
                         replay='static')
    got = res['values']
    np.testing.assert_allclose(got['gain_n_per_pa'], 3.4e-3, rtol=0.01)
    np.testing.assert_allclose(got['threshold_pressure_pa'], 7.5e4, rtol=0.01)
    np.testing.assert_allclose(got['damping_ratio'], 0.4, rtol=0.01)
    assert res['rms_after']['isometric'] < 0.1 * res['rms_before']['isometric']
    assert res['flags'] == []


def test_calibrate_without_readable_bags_is_one_line(tmp_path: pathlib.Path,
                                                     capsys: pytest.CaptureFixture) -> None:
    from pam_bench.cli import main
    assert main(['calibrate', str(tmp_path / 'nothing')]) == 2
    err = capsys.readouterr().err
    assert err.startswith('error:') and err.count('\n') == 1


def test_the_demos_readings_are_named_and_the_protocol_to_record_said(
        demo_bag: pathlib.Path, capsys: pytest.CaptureFixture) -> None:
    """The demo's 24 readings are a ramp's (taken while the voltage moves): calibrate names
    them and the protocols that would do, in one line, before it starts."""
    from pam_bench.bags.bagread import read_bags
    from pam_bench.cli import main
    from pam_bench.fit.calibrate_bags import observations_from_bags
    obs = observations_from_bags(read_bags([demo_bag]))
    assert obs.readings == [] and obs.left_aside == (
        'demo (24 readings): a ramp, its readings taken while the voltage moves',)
    assert main(['calibrate', str(demo_bag)]) == 2
    captured = capsys.readouterr()
    assert captured.err.count('\n') == 1 and 'demo (24 readings): a ramp' in captured.err
    assert 'isometric_quick' in captured.err and 'fitting' not in captured.out


@pytest.mark.parametrize('replay, isotonic_mm', [('stepped', 0.15), ('static', 0.6)])
def test_replay_of_a_twin_run_at_its_true_parameters(replay: str, isotonic_mm: float) -> None:
    """The readings of a protocol run of the time-stepped twin, replayed with the same
    parameters: the stepped replay (004's drive, a coarser sub-step while the force loop
    settles) lands within 0.15 mm RMS, the quasi-static one within 0.6 mm (its ideal drive
    leaves out the transient that places the muscle in its friction loop)."""
    from pam_bench.fit.calibrate_bags import Bench, observations_from_twin, rms_by_kind
    from pam_bench.models.sensors import LoadCellParams
    from pam_bench.models.valve import ValveParams
    from pam_bench.twin.protocol_run import run_protocol
    valve, muscle = ValveParams(), MuscleParams()
    run = run_protocol('isotonic_quick', 3.0, valve=valve, muscle=muscle,
                       load_cell=LoadCellParams(noise=False))
    obs = observations_from_twin(run.points, run.records)
    assert len(obs.readings) == 42
    assert rms_by_kind(obs, Bench(valve, muscle), replay=replay)['isotonic'] < isotonic_mm


@pytest.mark.parametrize('omega_rad_s, one_sub_step_n', [(300.0, 1.0), (31.4, None)])
def test_step_records_of_a_fast_valve_replay_at_the_true_parameters(
        omega_rad_s: float, one_sub_step_n: float | None, monkeypatch: pytest.MonkeyPatch
        ) -> None:
    """Step records (noise off) replayed at the true parameters: in sub-steps of the sample
    period (``record_sub_step_s``) they land within 0.12 N RMS; one 10 ms sub-step per
    compared sample leaves about 2 N at 300 rad/s (the top of the fit interval), a bias a fit
    pays for with wrong parameters. At 004's 5 Hz loop one sub-step would do nearly as well."""
    from pam_bench.fit import calibrate_replay
    from pam_bench.fit.calibrate_bags import Bench, observations_from_twin, rms_by_kind
    from pam_bench.models.sensors import LoadCellParams
    from pam_bench.models.valve import ValveParams
    from pam_bench.twin.protocol_run import run_protocol
    table = {'steps': {'kind': 'step_response', 'x_m': [0.0, 0.08, 0.04],
                       'up': {'u0_v': 1.0, 'step_v': 4.0, 'n': 1},
                       'down': {'u0_v': 5.0, 'step_v': -4.0, 'n': 1},
                       'dwell_s': 3.0, 'record_s': 1.0, 'sample_period_s': 0.001}}
    valve = dataclasses.replace(ValveParams(), natural_frequency_rad_s=omega_rad_s,
                                damping_ratio=0.6)
    bench = Bench(valve, MuscleParams())
    run = run_protocol('steps', 3.0, table=table, valve=valve, muscle=bench.muscle,
                       load_cell=LoadCellParams(noise=False))
    obs = observations_from_twin(run.points, run.records)
    assert len(obs.records) == 6
    rule = rms_by_kind(obs, bench)['step_records']
    assert rule < 0.12
    assert calibrate_replay.record_sub_step_s(0.001, omega_rad_s) == pytest.approx(0.001)
    monkeypatch.setattr(calibrate_replay, 'record_sub_step_s',              # one sub-step
                        lambda period_s, _: period_s * calibrate_replay.RECORD_STRIDE)
    one = rms_by_kind(obs, bench)['step_records']
    if one_sub_step_n is None:
        assert one < 0.12
    else:
        assert one > one_sub_step_n


def test_an_unknown_replay_is_an_error() -> None:
    from pam_bench.fit.calibrate_bags import Bench, Observations, predict
    from pam_bench.models.errors import ModelError
    from pam_bench.models.valve import ValveParams
    with pytest.raises(ModelError, match="'stepd'"):
        predict(Observations([], []), Bench(ValveParams(), MuscleParams()), replay='stepd')


def test_a_parameter_the_recordings_do_not_reach_stays_at_its_start_and_is_flagged() -> None:
    """campaign_quick has no reading past x_m once its 6 V, 50 N isobaric readings are left
    out, so the gain's rise there is free: the weak prior keeps it at its starting value
    (the data's small errors carried it to -97 % without), and it is flagged."""
    from pam_bench.fit.calibrate_bags import calibrate_bags
    from pam_bench.models.valve import ValveParams
    true_m = dataclasses.replace(MuscleParams(), gain_n_per_pa=3.4e-3)
    obs = _exact_observations(ValveParams(), true_m)
    res = calibrate_bags(obs, max_nfev=15, only=('gain_n_per_pa', 'gain_rise_n_per_pa_m'),
                         replay='static')
    assert res['left_out'] == [('isobaric', 6.0, 50.0)] * 2
    np.testing.assert_allclose(res['values']['gain_n_per_pa'], 3.4e-3, rtol=0.01)
    np.testing.assert_allclose(res['values']['gain_rise_n_per_pa_m'],
                               MuscleParams().gain_rise_n_per_pa_m, rtol=0.01)
    assert res['flags'] == ['gain_rise_n_per_pa_m']


def test_calibrate_cli_names_the_readings_it_leaves_out(tmp_path: pathlib.Path,
                                                         capsys: pytest.CaptureFixture) -> None:
    from pam_bench.cli import main
    _isobaric_bag(tmp_path / 'bag')
    assert main(['calibrate', str(tmp_path / 'bag'), '--replay', 'static',
                 '--max-evaluations', '1', '--starts', '0']) in (0, 3)   # not its point
    out = capsys.readouterr().out
    left = [line for line in out.splitlines() if line.startswith('left out')]
    assert len(left) == 1 and left[0].endswith(': isobaric 6 V 50 N'), out


def test_the_bench_a_bag_was_recorded_on_comes_from_its_scene(tmp_path: pathlib.Path) -> None:
    """``calibrate --scene``: the muscle's size (and every value the fit does not free) from
    the scene the bags were recorded on; no scene: the bench's defaults."""
    from pam_bench.config.scene import scenes_dir
    from pam_bench.fit.calibrate_bags import bench_of_scene
    scene = tmp_path / 'small.yaml'
    scene.write_text((scenes_dir() / 'campaign_quick.yaml').read_text()
                     + 'parameters:\n  muscle_1: {muscle: {nominal_diameter_m: 0.01}}\n')
    valve, muscle, servo = bench_of_scene(str(scene))
    assert muscle is not None and muscle.nominal_diameter_m == 0.01
    assert muscle.nominal_length_m == MuscleParams().nominal_length_m
    assert valve is not None and servo is not None
    assert bench_of_scene(None) == (None, None, None)


@pytest.mark.parametrize('scene, says', [('campain_quick', "no scene 'campain_quick'")])
def test_calibrate_with_a_bad_scene_is_one_line_and_writes_nothing(
        tmp_path: pathlib.Path, capsys: pytest.CaptureFixture, scene: str, says: str) -> None:
    from pam_bench.cli import main
    from test.analysis.bags import write_bag
    write_bag(tmp_path / 'bag', [
        dict(protocol='isobaric_quick', series=0, step=0, direction=0, series_value=2.0,
             set_value=50.0, voltage=2.0, force=50.0, contraction=0.07, pressure=2e5)])
    for extra in ([], ['--each']):
        code = main(['calibrate', str(tmp_path / 'bag'), '--scene', scene, '--out',
                     str(tmp_path / 'out'), *extra])
        err = capsys.readouterr().err
        assert code != 0 and says in err and err.count('\n') == 1, err
        assert not (tmp_path / 'out').exists()


def test_every_fit_interval_lies_in_the_declared_range_and_says_why() -> None:
    from pam_bench.fit.calibrate_bags import BOUND_REASONS, FREE_BAGS
    from pam_bench.models.valve import ValveParams
    from pam_bench.vocabulary.params import param_infos
    infos = {(m, i.name): i for m, cls in (('muscle', MuscleParams), ('valve', ValveParams))
             for i in param_infos(cls)}
    for model, name, lo, hi in FREE_BAGS:
        assert lo < hi and BOUND_REASONS[name], name
        if name == 'friction_stiffness_scale':     # a factor on the declared stiffnesses
            continue
        info = infos[(model, name)]
        assert info.low is not None and info.high is not None
        assert info.low <= lo and hi <= info.high, name
    assert set(BOUND_REASONS) == {n for _, n, _, _ in FREE_BAGS}
    widths = {n: lo for _, n, lo, _ in FREE_BAGS}
    assert widths['threshold_width_pa'] == 0.0      # a sharp threshold can be fitted


@pytest.mark.parametrize('rho', [0.0, 0.6, -0.95, 0.999999])
def test_covariance_matches_a_linear_problem_with_a_known_one(rho: float) -> None:
    """y = A theta + e, e ~ N(0, s^2): cov(theta) = s^2 (A^T A)^-1 exactly. A is built so that
    the correlation of the two estimates is -rho; a third column repeats the first (a
    direction the data do not see), which gets zero variance and zero correlations."""
    from pam_bench.fit.calibrate import covariance
    a = np.array([[1.0, rho], [0.0, np.sqrt(1.0 - rho ** 2)], [1.0, 0.0], [0.0, 1.0]])
    cov, corr = covariance(a, 2.0)
    want = 2.0 * np.linalg.inv(a.T @ a)
    np.testing.assert_allclose(cov, want, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(corr[0, 1], want[0, 1] / np.sqrt(want[0, 0] * want[1, 1]),
                               rtol=1e-9, atol=1e-12)
    assert np.all(np.abs(corr) <= 1.0)
    degenerate = np.column_stack([a, a[:, 0]])
    cov3, corr3 = covariance(degenerate, 2.0)
    assert np.all(np.isfinite(cov3)) and np.all(np.abs(corr3) <= 1.0)
    np.testing.assert_allclose(np.diag(cov3) >= 0, True)


def test_correlations_of_ill_conditioned_jacobians_stay_in_range() -> None:
    """Random near-singular Jacobians (columns nearly repeated, scales 1e-8 to 1e8): the
    correlations come out in [-1, 1] before any clip would act."""
    from pam_bench.fit.calibrate import covariance
    rng = np.random.default_rng(7)
    for _ in range(50):
        j = rng.normal(size=(30, 6)) * 10.0 ** rng.uniform(-8, 8, size=6)
        j[:, 5] = j[:, 4] * 1.000001 + 1e-9 * rng.normal(size=30)
        cov, _ = covariance(j, 1.0)
        sd = np.sqrt(np.diag(cov))
        ok = sd > 0
        raw = cov[np.ix_(ok, ok)] / np.outer(sd[ok], sd[ok])
        assert np.all(np.abs(raw) <= 1.0 + 1e-9)


def test_a_value_at_its_bound_is_reported_so_without_an_error() -> None:
    from pam_bench.fit.calibrate import fit_report
    summary = {'names': ['a', 'b'], 'values': {'a': 0.0, 'b': 2.0},
               'stderr': {'a': 9.5e-12, 'b': 0.1}, 'flags': ['a'], 'at_bound': ['a']}
    rep = fit_report(summary)
    assert 'at its bound' in rep['a'] and '+-' not in rep['a']
    assert rep['b'].split() == ['2', '+-', '0.1']


@pytest.mark.parametrize('z_end, z_best', [(0.40, 0.50), (0.70, 0.55), (0.30, 0.30)])
def test_the_gauss_newton_share_is_the_step_to_a_linear_optimum(z_end: float,
                                                                z_best: float) -> None:
    """On residuals linear in z, r = 2 (z - z*), the Gauss-Newton step from z lands on z*: its
    share of the value theta = lower + z span is (z* - z) span / theta."""
    from types import SimpleNamespace

    from pam_bench.fit.calibrate_bags import gauss_newton_share
    lower, span = np.array([1.0, -4.0]), np.array([10.0, 2.0])
    z = np.array([z_end, z_end])
    sol = SimpleNamespace(x=z, jac=2.0 * np.eye(2), fun=2.0 * (z - z_best))
    theta = lower + z * span
    np.testing.assert_allclose(gauss_newton_share(sol, lower, span),
                               (z_best - z_end) * span / np.abs(theta), rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize('offset', [0.0, 0.01, 0.05])
def test_the_gauss_newton_gain_is_the_chi_square_a_linear_step_buys(offset: float) -> None:
    """Data residuals linear in z, r = J (z - z*) + e (e: noise of unit variance, orthogonal
    to J's columns), and the prior's rows after them: the step to the optimum lowers the
    chi-square by |J (z - z*)|^2, in units of the data's residual variance |r|^2 / (m - n)."""
    from types import SimpleNamespace

    from pam_bench.fit.calibrate_bags import gauss_newton_gain
    rng = np.random.default_rng(7)
    m, n = 400, 3
    jac = rng.normal(size=(m, n)) * 20.0
    e = rng.normal(size=m)
    e -= jac @ np.linalg.lstsq(jac, e, rcond=None)[0]          # orthogonal to the columns
    dz = np.full(n, offset)
    data = jac @ dz + e
    sol = SimpleNamespace(x=0.5 + dz, jac=np.vstack([jac, np.zeros((n, n))]),
                          fun=np.concatenate([data, np.zeros(n)]))
    s2 = float(data @ data) / (m - n)
    np.testing.assert_allclose(gauss_newton_gain(sol, m), float(np.sum((jac @ dz) ** 2)) / s2,
                               rtol=1e-9, atol=1e-9)


def test_a_bag_is_replayed_on_the_muscle_it_declares(tmp_path: pathlib.Path,
                                                      ros_domain: int) -> None:
    """A bag made with a muscle of another size: calibrate holds what it does not fit at that
    muscle, from the bag's run description, not at the defaults (the valve's loop scales with
    the chamber it sees)."""
    import subprocess
    import sys

    from pam_bench.fit.calibrate_bags import bench_of_bags
    res = subprocess.run([sys.executable, '-m', 'pam_bench.cli', 'run', 'demo', '--set',
                          'muscle_1.muscle.nominal_length_m=0.25', '--set',
                          'muscle_1.muscle.nominal_diameter_m=0.03', '--out',
                          str(tmp_path / 'bag')], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    valve, muscle, drive = bench_of_bags([str(tmp_path / 'bag')])
    assert muscle is not None and valve is not None and drive is not None
    assert (muscle.nominal_length_m, muscle.nominal_diameter_m) == (0.25, 0.03)
    assert bench_of_bags([str(tmp_path / 'nothing')]) == (None, None, None)


def test_calibrate_json_keeps_stdout_to_the_json(tmp_path: pathlib.Path,
                                                  capsys: pytest.CaptureFixture) -> None:
    """``--json``: what a script parses is on stdout alone, strict JSON (a held parameter's
    standard error, undefined, is null, not NaN); the progress lines go to stderr."""
    import json

    from pam_bench.cli import main
    _isobaric_bag(tmp_path / 'bag')
    assert main(['calibrate', str(tmp_path / 'bag'), '--replay', 'static', '--json',
                 '--max-evaluations', '1', '--starts', '0']) in (0, 3)
    captured = capsys.readouterr()
    res = json.loads(captured.out, parse_constant=lambda c: pytest.fail(f'{c} is not JSON'))
    assert 'verdict' in res and 'values' in res
    assert None in res['stderr'].values()            # the held parameters' undefined errors
    assert 'fitting the muscle and valve' in captured.err


def test_a_jacobian_with_huge_columns_gives_a_step_not_a_traceback() -> None:
    """A law with an exponential gave forces of 1e199 N at a finite-difference trial: the
    Gauss-Newton step at the fit's end (``gauss_newton_share``) overflowed J^T J and numpy's
    SVD failed with a traceback. Solved on J itself, the step is finite."""
    import types

    from pam_bench.fit.calibrate_bags import gauss_newton_share
    jac = np.array([[1.0, 5e199], [2.0, 0.0], [0.0, 1.0]])
    sol = types.SimpleNamespace(jac=jac, fun=np.array([0.01, -0.02, 0.0]), x=np.array([0.5, 0.5]))
    step = gauss_newton_share(sol, np.zeros(2), np.ones(2))
    assert np.all(np.isfinite(step))
    np.testing.assert_allclose(step[0], 0.02, rtol=1e-6)        # -(0.01, -0.02) on column 1


def test_the_law_start_fits_the_mean_of_the_two_branches() -> None:
    """Rising and falling isometric readings at one (u, x) differ by the friction either way:
    the law's start is fitted to their mean."""
    from pam_bench.fit.calibrate_init import _branch_means
    iso = [(1.0, 0.0, 100.0), (2.0, 0.0, 210.0), (1.0, 0.0, 96.0), (2.0, 0.04, 150.0)]
    assert sorted(_branch_means(iso)) == [(1.0, 0.0, 98.0), (2.0, 0.0, 210.0),
                                          (2.0, 0.04, 150.0)]


def _isobaric_bag(path: pathlib.Path) -> None:
    """A small isobaric bag: two voltages, two loads."""
    from test.analysis.bags import write_bag
    rows = [(2.0, 50.0, 0.070), (2.0, 150.0, 0.048), (6.0, 50.0, 0.112), (6.0, 150.0, 0.085)]
    write_bag(path, [
        dict(protocol='isobaric_quick', series=int(u > 2.0), step=k, direction=0,
             series_value=u, set_value=f, voltage=u, force=f, contraction=x, pressure=u * 1e5)
        for k, (u, f, x) in enumerate(rows)])


def test_a_step_protocols_readings_are_the_records_starts_not_isometric_readings(
        tmp_path: pathlib.Path) -> None:
    """The step records' settled starts (a step_response protocol's readings, held x while the
    voltage changes) stay out of the static readings, named, as the twin's observations leave
    them out; the isometric protocol's are kept."""
    from pam_bench.bags.bagread import read_bags
    from pam_bench.fit.calibrate_bags import observations_from_bags
    from test.analysis.bags import write_bag
    iso = [dict(protocol='isometric_quick', series=0, step=k, direction=0, series_value=0.04,
                set_value=0.04, voltage=u, force=100.0 * u, contraction=0.04, pressure=u * 1e5)
           for k, u in enumerate((1.0, 2.0, 3.0))]
    steps = [dict(protocol='step_response_quick', series=k, step=0, direction=0,
                  series_value=x, set_value=x, voltage=u, force=f, contraction=x,
                  pressure=u * 1e5)
             for k, (u, x, f) in enumerate([(3.0, 0.0, 665.0), (5.0, 0.0, 1288.0),
                                            (3.0, 0.04, 317.0)])]
    write_bag(tmp_path / 'bag', iso + steps)
    obs = observations_from_bags(read_bags([tmp_path / 'bag']))
    assert [r[:3] for r in obs.readings] == [('isometric', u, 0.04) for u in (1.0, 2.0, 3.0)]
    assert obs.left_aside == ("step_response_quick (3 readings): the step records' settled "
                              'starts, compared in the records themselves',)
