"""A lab's own load-cell driver beside the simulated bench (issue 52): the driver of
docs/drivers.md, a plain rclpy node, run as the page gives it; ``run --wallclock --external
load_cell_1`` waits for it, says so, and the readings land within 10 N of lock-step."""

from __future__ import annotations

import os
import pathlib
import re
import subprocess
import sys

import pytest

from pam_bench.bags.bagread import read_bags

pytestmark = pytest.mark.wallclock

DOC = pathlib.Path(__file__).parents[2] / 'docs' / 'drivers.md'
SCENE = """description: short isometric series beside a lab's load cell
exchange_step_s: 1.5
protocol: isometric_quick
protocol_overrides: {x_m: [0.04, 0.04, 0.01], voltage_v: [0.0, 2.0, 1.0], dwell_s: 1.5}
nodes: [valve_1, muscle_1, load_cell_1, encoder, loading_servo, sequencer, recorder]
"""


def driver_code() -> str:
    """The worked example's driver, as docs/drivers.md gives it."""
    blocks = re.findall(r'```python\n(.*?)```', DOC.read_text(), re.S)
    code = next(b for b in blocks if 'class MyLoadCell' in b)
    assert 'pam_bench.' not in code.replace('pam_bench_interfaces', '')   # no pam_bench import
    return code


def test_a_foreign_load_cell_runs_a_protocol(tmp_path: pathlib.Path, ros_domain: int) -> None:
    scene = tmp_path / 'short.yaml'
    scene.write_text(SCENE)
    driver = tmp_path / 'my_load_cell.py'
    driver.write_text(driver_code())
    log = tmp_path / 'my_load_cell.log'
    env = {**os.environ, 'ROS_DOMAIN_ID': str(ros_domain)}
    lock = subprocess.run([sys.executable, '-m', 'pam_bench.cli', 'run', str(scene), '--out',
                           str(tmp_path / 'lock')], env=env, capture_output=True, text=True,
                          timeout=120)
    assert lock.returncode == 0, lock.stdout + lock.stderr
    run = subprocess.Popen([sys.executable, '-m', 'pam_bench.cli', 'run', str(scene),
                            '--wallclock', '--external', 'load_cell_1', '--out',
                            str(tmp_path / 'wall')], env=env, stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, text=True)
    mine = None
    try:
        assert run.stdout is not None
        lines = []
        for line in run.stdout:                     # it says what it waits for
            lines.append(line)
            if line.startswith('waiting for load_cell_1'):
                break
        assert 'topic not published' in lines[-1], ''.join(lines)
        with log.open('w') as sink:               # a file: a pipe nobody reads can fill
            mine = subprocess.Popen([sys.executable, str(driver)], env=env, stdout=sink,
                                    stderr=subprocess.STDOUT, text=True)
        out = ''.join(lines) + run.communicate(timeout=120)[0]
    finally:
        for p in (run, mine):
            if p is not None and p.poll() is None:
                p.terminate()
                try:
                    p.wait(timeout=20)
                except subprocess.TimeoutExpired:   # reported below, not left running
                    p.kill()
                    p.wait()
    assert mine is not None and mine.returncode == 0, log.read_text()   # SIGTERM: a clean exit
    assert run.returncode == 0, out
    assert 'external load_cell_1: meets the driver contract' in out, out
    wall = read_bags([tmp_path / 'wall']).points['isometric_quick']
    ref = read_bags([tmp_path / 'lock']).points['isometric_quick']
    assert len(wall) == len(ref) == 6
    assert max(abs(wall.force_n - ref.force_n)) < 10.0, (wall.force_n, ref.force_n)
