"""Self-describing bags: how a run was made and ended, info, replay, diff."""

from __future__ import annotations

import json
import os
import pathlib
import re
import subprocess
import sys

import yaml

from pam_bench.bags.bagdiff import diff_bags
from pam_bench.bags.baginfo import bag_info, run_of_bag

SHORT = pathlib.Path(__file__).resolve().parents[1] / 'config_short.yaml'


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, '-m', 'pam_bench.cli', *args], capture_output=True,
                          text=True, timeout=120)


def test_a_bag_says_how_it_was_made_and_replays_to_the_same_readings(
        tmp_path: pathlib.Path, ros_domain: int) -> None:
    a, b = tmp_path / 'a', tmp_path / 'b'
    res = _cli('run', str(SHORT), '--seed', '7', '--out', str(a))
    assert res.returncode == 0, res.stderr
    run = run_of_bag(a)
    assert run['scene'] == 'config_short' and run['seed'] == 7
    assert run['scene_text'] == SHORT.read_text()
    assert run['layout'] == 'composed' and '--seed' in run['command_line']
    assert run['parameters']['load_cell_1']['ros__parameters']['seed'] == 7
    assert re.fullmatch('[0-9a-f]{40}', run['commit']), run['commit']   # run in the checkout
    assert isinstance(run['dirty'], bool)
    assert set(run['versions']) >= {'pam_bench', 'rclpy', 'rosbags', 'numpy'}
    info = bag_info(a)
    assert info['end']['state'] == 'done' and info['end']['code'] == 0
    assert info['topics']['/protocol/point']['count'] == 8
    # the same text sits in the MCAP file's rosbag2 metadata record
    from mcap.reader import make_reader
    with open(next(a.glob('*.mcap')), 'rb') as fh:
        meta = {m.name: m.metadata for m in make_reader(fh).iter_metadata()}
    custom = yaml.safe_load(meta['rosbag2']['serialized_metadata'])['custom_data']
    assert yaml.safe_load(custom['pam_bench.run'])['seed'] == 7
    printed = _cli('info', str(a), '--parameters')
    assert printed.returncode == 0 and 'config_short (seed 7' in printed.stdout
    assert 'ended     done' in printed.stdout
    assert 'load_cell_1: ' in printed.stdout and 'seed=7' in printed.stdout
    # replay: its own scene, parameters and seed; zero difference reading by reading
    res = _cli('run', '--replay', str(a), '--out', str(b))
    assert res.returncode == 0, res.stderr
    d = diff_bags(a, b)
    assert d['demo_short']['matched'] == 8
    assert all(v == 0 for k, v in d['demo_short'].items() if k.startswith(('max_', 'only_')))
    res = _cli('diff', str(a), str(b), '--json')
    assert res.returncode == 0 and 'identical readings' in res.stdout


def test_a_run_leaves_no_end_state_file_behind(tmp_path: pathlib.Path, ros_domain: int) -> None:
    temp = tmp_path / 'tmp'
    temp.mkdir()
    env = {**os.environ, 'TMPDIR': str(temp)}
    res = subprocess.run([sys.executable, '-m', 'pam_bench.cli', 'run', str(SHORT), '--out',
                          str(tmp_path / 'a')], capture_output=True, text=True, timeout=120,
                         env=env)
    assert res.returncode == 0, res.stderr
    assert bag_info(tmp_path / 'a')['end']['state'] == 'done'
    assert not [p.name for p in temp.iterdir() if p.name.startswith('pam_bench_end_')]


def test_diff_reports_a_different_seed(tmp_path: pathlib.Path, ros_domain: int) -> None:
    a, b = tmp_path / 'a', tmp_path / 'b'
    for bag, seed in ((a, '1'), (b, '2')):
        assert _cli('run', str(SHORT), '--seed', seed, '--out',
                    str(bag)).returncode == 0
    res = _cli('diff', str(a), str(b), '--json')
    assert res.returncode == 1 and 'the bags differ' in res.stdout
    d = json.loads(res.stdout[:res.stdout.rindex('}') + 1])
    assert 0 < d['demo_short']['max_force_n'] < 5.0          # sensor noise only


def test_an_interrupted_run_says_so(tmp_path: pathlib.Path, ros_domain: int) -> None:
    import os
    import signal
    import time
    bag = tmp_path / 'bag'
    proc = subprocess.Popen([sys.executable, '-m', 'pam_bench.cli', 'run', 'isometric',
                             '--out', str(bag)], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, start_new_session=True)
    try:
        for line in proc.stdout:
            if line.startswith('[sim'):
                break
        time.sleep(0.5)
        os.killpg(proc.pid, signal.SIGINT)
        proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert bag_info(bag)['end']['state'] == 'interrupted'
