"""`pam-bench run` as a user meets it: one process, bad node parameters, exit codes."""

from __future__ import annotations

import pathlib
import subprocess
import sys
import time

import pytest

from test.helpers import bag_messages

SHORT = pathlib.Path(__file__).resolve().parents[1] / 'config_short.yaml'


def _run(args: list[str], timeout: float = 120.0) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, '-m', 'pam_bench.cli', 'run', *args],
                          capture_output=True, text=True, timeout=timeout)


def test_a_run_composes_by_default_and_exits_0_with_a_valid_bag(
        tmp_path: pathlib.Path, ros_domain: int) -> None:
    from pam_bench.bags.baginfo import run_of_bag
    bag = tmp_path / 'bag'
    res = _run([str(SHORT), '--out', str(bag)])
    assert res.returncode == 0, res.stdout + res.stderr
    assert 'Traceback' not in res.stderr
    assert 'done:' in res.stdout
    assert len(bag_messages(bag, '/protocol/point')) == 8
    assert run_of_bag(str(bag))['layout'] == 'composed'


@pytest.mark.parametrize('one_process', [False, True])
@pytest.mark.parametrize('params, words', [
    ('sequencer: {stale_timout_s: 1.0}',
     ["'sequencer.stale_timout_s'", "did you mean 'sequencer.stale_timeout_s'"]),
    ('sequencer: {tick_period_s: 5.0}', ['tick_period_s']),
    ('sequencer: {protocol_overrides_yaml: "dwel_s: 1"}', ["'dwel_s'"]),
])
def test_a_bad_node_parameter_stops_the_run_with_one_line(
        tmp_path: pathlib.Path, ros_domain: int, one_process: bool, params: str,
        words: list[str]) -> None:
    scene = tmp_path / 'bad.yaml'
    scene.write_text(SHORT.read_text() + f'\nparameters:\n  {params}\n')
    t0 = time.monotonic()
    res = _run([str(scene), '--out', str(tmp_path / 'bag')]
               + ([] if one_process else ['--processes']))
    assert res.returncode == 2, res.stdout + res.stderr
    assert time.monotonic() - t0 < 30.0            # not after the clock's stall timeout
    assert 'Traceback' not in res.stderr, res.stderr
    errors = [line for line in res.stderr.splitlines() if 'error' in line]
    assert errors and all(w in errors[0] for w in words), res.stderr


def test_a_misspelt_scene_key_is_refused_before_anything_starts(tmp_path: pathlib.Path) -> None:
    scene = tmp_path / 'bad.yaml'
    scene.write_text(SHORT.read_text() + '\nparameters:\n  muscle_1: {muscle: '
                     '{gain_exponnent: 2.0}}\n')
    res = _run([str(scene), '--out', str(tmp_path / 'bag')], timeout=30)
    assert res.returncode == 2
    assert res.stderr.strip().count('\n') == 0, res.stderr
    assert "did you mean 'muscle_1.muscle.gain_exponent'" in res.stderr
    assert not (tmp_path / 'bag').exists()


def test_the_readme_path_demo_then_extract_writes_a_report(tmp_path: pathlib.Path,
                                                           ros_domain: int) -> None:
    """README's first steps: `make demo` records bags/demo (a ramp at x = 20 mm), then
    `pam-bench extract bags/demo --out reports/demo` writes F(u) both ways and its gain."""
    import json
    bag, out = tmp_path / 'demo', tmp_path / 'report'
    res = _run(['demo', '--out', str(bag)])
    assert res.returncode == 0, res.stdout + res.stderr
    ext = subprocess.run([sys.executable, '-m', 'pam_bench.cli', 'extract', str(bag), '--out',
                          str(out)], capture_output=True, text=True, timeout=120)
    assert ext.returncode == 0, ext.stdout + ext.stderr
    summary = json.loads((out / 'summary.json').read_text())
    iso = summary['isometric']
    assert iso['protocol'] == 'demo' and [s['x_mm'] for s in iso['series']] == \
        pytest.approx([20.0])
    # the muscle's isometric gain at 20 mm is about 200 N/V (004: 284 N/V at 0 mm, falling)
    assert 150.0 < iso['gain_N_per_V']['max'] < 260.0
    assert {'demo_family.png', 'isometric_gain.png'} <= set(summary['figures'])
    assert 'Isometric gain at x = 20 mm' in (out / 'report.md').read_text()


@pytest.mark.parametrize('verb', [['run', 'demo'], ['record', '--out', 'x']])
@pytest.mark.parametrize('flag, value', [('--max-bag-size', 'lots'), ('--max-bag-size', '-5M'),
                                         ('--max-bag-duration', 'soon'),
                                         ('--max-bag-duration', '-1h')])
def test_a_bad_bag_limit_is_one_line_before_anything_starts(
        verb: list[str], flag: str, value: str, capsys: pytest.CaptureFixture) -> None:
    from pam_bench.cli import main
    with pytest.raises(SystemExit) as exc:
        main([*verb, flag, value])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert err.count('\n') == 1 and flag in err and 'error' in err, err
