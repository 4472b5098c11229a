"""Sweeps: a strict file, jobs, a resumable results.csv equal on one worker and on two."""

from __future__ import annotations

import csv
import pathlib

import pytest

from pam_bench.config.errors import ConfigError
from pam_bench.sweep.jobs import figure_of
from pam_bench.sweep.results import RESULTS, run_sweep
from pam_bench.sweep.spec import load_sweep

SMALL = """description: small
scene: isometric_quick
engine: twin
seeds: [1, 2]
grid:
  muscle_1.muscle.gain_exponent: [1.3, 1.4]
figures: [isometric.gain_N_per_V.max, isometric.gain_N_per_V.min, run.exit_code]
"""


def _write(tmp_path: pathlib.Path, text: str, name: str = 'small.yaml') -> pathlib.Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def _table(path: pathlib.Path, drop: tuple[str, ...] = ('seconds',)) -> list[dict[str, str]]:
    with open(path, newline='') as fh:
        return [{k: v for k, v in row.items() if k not in drop} for row in csv.DictReader(fh)]


@pytest.mark.parametrize('text, words', [
    (SMALL.replace('grid:', 'gird:'), ["'gird'", "did you mean 'grid'"]),
    (SMALL.replace('gain_exponent', 'gain_exponant'),
     ["'muscle_1.muscle.gain_exponant'", "'muscle_1.muscle.gain_exponent'"]),
    (SMALL.replace('[1.3, 1.4]', '[1.3, 99.0]'), ['gain_exponent', 'maximum']),
    (SMALL.replace('isometric.gain_N_per_V.max', 'isometrik.gain_N_per_V.max'),
     ["'isometrik.gain_N_per_V.max'", "did you mean 'isometric'"]),
    (SMALL.replace('engine: twin', 'engine: rso'), ["'rso'", "did you mean 'ros'"]),
    (SMALL.replace('seeds: [1, 2]', 'seeds: [-1]'), ['seeds']),
])
def test_a_bad_sweep_is_one_line_naming_the_key(tmp_path: pathlib.Path, text: str,
                                               words: list[str]) -> None:
    with pytest.raises(ConfigError) as info:
        load_sweep(_write(tmp_path, text))
    assert '\n' not in str(info.value) and str(info.value).startswith('sweep small.yaml')
    for w in words:
        assert w in str(info.value), str(info.value)


def test_grid_list_and_random_draws(tmp_path: pathlib.Path) -> None:
    assert len(load_sweep(_write(tmp_path, SMALL)).jobs()) == 4
    listed = SMALL.replace("""grid:
  muscle_1.muscle.gain_exponent: [1.3, 1.4]""", """list:
  - {muscle_1.muscle.gain_exponent: 1.3, valve_1.valve.damping_ratio: 0.4}
  - {muscle_1.muscle.gain_exponent: 1.4}""")
    sw = load_sweep(_write(tmp_path, listed))
    assert [dict(j.values) for j in sw.jobs()][::2] == [
        {'muscle_1.muscle.gain_exponent': 1.3, 'valve_1.valve.damping_ratio': 0.4},
        {'muscle_1.muscle.gain_exponent': 1.4}]
    drawn = SMALL.replace("""grid:
  muscle_1.muscle.gain_exponent: [1.3, 1.4]""", """random: {n: 5, seed: 7, ranges: {
  muscle_1.muscle.gain_exponent: [1.2, 1.5], muscle_1.straight_fibre.segments: [2, 5]}}""")
    a, b = load_sweep(_write(tmp_path, drawn)), load_sweep(_write(tmp_path, drawn))
    assert [j.values for j in a.jobs()] == [j.values for j in b.jobs()]     # the seed fixes
    values = [dict(j.values) for j in a.jobs()]
    assert all(1.2 <= v['muscle_1.muscle.gain_exponent'] <= 1.5 for v in values)
    assert all(isinstance(v['muscle_1.straight_fibre.segments'], int) for v in values)


def test_figure_lookup() -> None:
    r = {'a': {'b': [1.0, {'c': 2}]}, 'flag': True}
    assert figure_of(r, 'a.b.0') == 1.0 and figure_of(r, 'a.b.1.c') == 2.0
    assert str(figure_of(r, 'a.x')) == 'nan' and str(figure_of(r, 'flag')) == 'nan'


def test_one_and_two_workers_give_the_same_results_and_a_rerun_skips(
        tmp_path: pathlib.Path) -> None:
    sweep = load_sweep(_write(tmp_path, SMALL))
    one = run_sweep(sweep, tmp_path / 'one', {'workers': 1})
    two = run_sweep(sweep, tmp_path / 'two', {'workers': 2})
    assert all(r['status'] == 'ok' for r in one + two)
    assert _table(tmp_path / 'one' / RESULTS) == _table(tmp_path / 'two' / RESULTS)
    # the gain exponent moves the isometric gain minimum (the muscle law), seeds barely
    rows = _table(tmp_path / 'one' / RESULTS)
    lo = {float(r['muscle_1.muscle.gain_exponent']): float(r['isometric.gain_N_per_V.min'])
          for r in rows}
    assert lo[1.3] > lo[1.4]
    before = (tmp_path / 'one' / RESULTS).read_text()
    again = run_sweep(sweep, tmp_path / 'one', {'workers': 1})
    assert (tmp_path / 'one' / RESULTS).read_text() == before       # times kept: nothing ran
    assert [r['job'] for r in again] == [r['job'] for r in one]


def test_a_failed_job_is_reported_and_the_rest_complete(tmp_path: pathlib.Path) -> None:
    """A setting the muscle model refuses (an unstable gain rise) fails that job only."""
    text = SMALL.replace('muscle_1.muscle.gain_exponent: [1.3, 1.4]',
                         'muscle_1.muscle.gain_rise_n_per_pa_m: [0.0, 0.9]')
    rows = run_sweep(load_sweep(_write(tmp_path, text)), tmp_path / 'out', {'workers': 1})
    bad = [r for r in rows if r['status'] != 'ok']
    assert len(bad) == 2 and all('ModelError' in r['status'] for r in bad)
    assert len([r for r in rows if r['status'] == 'ok']) == 2


@pytest.mark.parametrize('name', ['identification', 'servo_tuning', 'straight_fibre_design'])
def test_the_shipped_sweeps_load(name: str) -> None:
    from pam_bench.config.paths import config_dir
    sweep = load_sweep(config_dir() / 'sweeps' / f'{name}.yaml')
    assert sweep.jobs() and sweep.figures


def test_an_interrupted_sweep_keeps_what_it_finished(tmp_path: pathlib.Path) -> None:
    """Issue 51: SIGINT in the middle of a sweep: every job that had finished is in
    results.csv, no scratch folder is left, and the rerun skips those jobs (their rows, wall
    times included, come back unchanged)."""
    import csv
    import os
    import signal
    import subprocess
    import sys
    import time
    out = tmp_path / 'sweep'
    env = {**os.environ, 'TMPDIR': str(tmp_path / 'tmp')}
    (tmp_path / 'tmp').mkdir()
    proc = subprocess.Popen([sys.executable, '-m', 'pam_bench.cli', 'sweep', 'servo_tuning',
                             '--out', str(out), '--no-plots'], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        end = time.monotonic() + 120.0
        while time.monotonic() < end and proc.poll() is None:
            if (out / 'results.csv').exists() and \
                    len((out / 'results.csv').read_text().splitlines()) > 3:
                break
            time.sleep(0.05)
        proc.send_signal(signal.SIGINT)
        text = proc.communicate(timeout=60)[0]
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130 and 'Traceback' not in text, text

    def rows() -> dict[str, dict[str, str]]:
        with open(out / 'results.csv', newline='', encoding='utf-8') as fh:
            return {r['job']: r for r in csv.DictReader(fh)}
    kept = rows()
    assert 3 <= len(kept) < 32 and all(r['status'] == 'ok' for r in kept.values())
    assert not [p.name for p in (tmp_path / 'tmp').iterdir()]       # no scratch left
    again = subprocess.run([sys.executable, '-m', 'pam_bench.cli', 'sweep', 'servo_tuning',
                            '--out', str(out), '--no-plots'], env=env, capture_output=True,
                           text=True, timeout=300)
    assert again.returncode == 0, again.stdout + again.stderr
    final = rows()
    assert len(final) == 32
    assert all(final[job] == row for job, row in kept.items())    # skipped, not run again
