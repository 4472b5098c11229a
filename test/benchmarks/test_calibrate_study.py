"""The calibrate study's sets: one per drawn parameter at an end of its fit interval."""

from __future__ import annotations

import dataclasses

import pytest

from benchmarks.calibrate import DRAWN, edge_parameters
from pam_bench.fit.calibrate_bags import FREE_BAGS
from pam_bench.models.muscle import MuscleParams
from pam_bench.models.valve import ValveParams


@pytest.mark.parametrize('k', range(len(DRAWN)))
def test_an_edge_set_moves_one_parameter_to_an_end_of_its_interval(k: int) -> None:
    valve, muscle, what = edge_parameters(k)
    name = DRAWN[k]
    model, _, lo, hi = next(row for row in FREE_BAGS if row[1] == name)
    changed = {(m, f.name) for m, obj, ref in (('valve', valve, ValveParams()),
                                               ('muscle', muscle, MuscleParams()))
               for f in dataclasses.fields(obj) if getattr(obj, f.name) != getattr(ref, f.name)}
    assert changed <= {(model, name)}
    value = getattr(valve if model == 'valve' else muscle, name)
    assert value == (lo if k % 2 == 0 else hi)
    assert name in what and ('lower' in what) == (k % 2 == 0)


def test_every_drawn_parameter_reaches_an_end_once() -> None:
    names = [edge_parameters(k)[2].split(' ')[0] for k in range(len(DRAWN))]
    assert sorted(names) == sorted(DRAWN)


def test_drawn_sets_are_muscles_the_model_takes() -> None:
    import numpy as np

    from benchmarks.calibrate import draw_parameters, invalid
    rng = np.random.default_rng(7)
    assert all(not invalid(*draw_parameters(rng)) for _ in range(30))
    bad = dataclasses.replace(MuscleParams(), bladder_stiffness_n_per_m=250.0,
                              gain_rise_n_per_pa_m=5e-4)
    assert 'bladder' in invalid(ValveParams(), bad)


def test_a_failing_study_is_reported_and_the_rest_run(tmp_path, monkeypatch) -> None:
    import json

    from benchmarks import suite
    from benchmarks.study import Study

    def boom(quick, out, scenes):
        raise RuntimeError('drawn muscle refused')
    studies = (Study('first', 'fails', boom, (('first', lambda r, root: []),)),
               Study('second', 'works', lambda q, o, s: {'second': {'x': 1}},
                     (('second', lambda r, root: ['second ran']),)))
    monkeypatch.setattr(suite, 'STUDIES', studies)
    monkeypatch.setattr(suite, 'render_report', lambda root: root / 'BENCHMARKS.md')
    report = suite.run_benchmarks(True, tmp_path)
    assert report['second'] == {'x': 1}
    assert 'drawn muscle refused' in report['failed']['first']['error']
    assert json.loads((tmp_path / 'results' / 'bench.json').read_text())['failed']['first']


def test_a_quick_run_leaves_out_a_study_marked_full_only(tmp_path, monkeypatch) -> None:
    from benchmarks import suite
    from benchmarks.study import Study
    studies = (Study('full', 'full run only', lambda q, o, s: {'full': {'x': 1}},
                     (('full', lambda r, root: []),), quick=False),
               Study('both', 'every run', lambda q, o, s: {'both': {'x': 2}},
                     (('both', lambda r, root: []),)))
    monkeypatch.setattr(suite, 'STUDIES', studies)
    monkeypatch.setattr(suite, 'render_report', lambda root: root / 'BENCHMARKS.md')
    assert 'full' not in suite.run_benchmarks(True, tmp_path)
    assert suite.run_benchmarks(True, tmp_path, only=['full'])['full'] == {'x': 1}
    (tmp_path / 'f').mkdir()
    assert suite.run_benchmarks(False, tmp_path / 'f')['full'] == {'x': 1}


def test_the_zoo_study_counts_false_verdicts_on_its_own_laws_only() -> None:
    """A made-up zoo report: a bag fitted with its own law and not converged is a false 'not
    converged'; one converged with a fixed parameter 8 % off a false 'converged' (a flagged
    one, or one whose truth is 0, does not count); the bench law's rows are counted apart."""
    from benchmarks.calibrate_zoo import BENCH_LAW, results, section

    def bag(law: str, fit: str, converged: bool, errors: dict, flags: list) -> dict:
        return {'law': law, 'seed': 1, 'fit': fit, 'converged': converged,
                'rms': {'isometric': 0.2}, 'tolerance': {'isometric': 0.6}, 'zero': ['c'],
                'errors': errors, 'flags': flags, 'fixed': 2, 'advice': [], 'fit_s': 3.0,
                'evaluations': 9}
    bags = [bag('a', 'a', False, {'p': 0.01}, []),
            bag('b', 'b', True, {'p': 0.08, 'c': 0.5}, []),
            bag('d', 'd', True, {'p': 0.08}, ['p']),
            bag('e', 'e', True, {'c': 0.5}, []),
            bag('a', BENCH_LAW, False, {}, ['x'])]
    r = {'calibrate_zoo': {'bags': bags, 'tolerance': 0.05}, 'measured': {}, 'commit': 'abc'}
    lines = section(r)
    assert lines[-1] == ("4 bags fitted with their own law: 1 'not converged', 1 'converged' "
                         "with a parameter reported fixed more than 5% off; 1 fitted with the "
                         "bench's McKibben law: 1 'not converged'.")
    assert results(r)[0][2] == '1 and 1 of 4'
