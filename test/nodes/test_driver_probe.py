"""`pam-bench check-drivers` on a running graph: the wall-clock simulation passes, each
deliberately broken driver fails with its own reason."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

pytestmark = pytest.mark.wallclock


def _start(args: list[str]) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, *args], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, start_new_session=True)


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGINT)
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)


def _check(scene: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, '-m', 'pam_bench.cli', 'check-drivers', scene,
                           '--duration', '2'], capture_output=True, text=True, timeout=60)


def _rows(out: str) -> dict[str, str]:
    return {line.split()[0]: line for line in out.splitlines() if line.startswith('/')}


def test_the_wallclock_simulation_meets_the_contract(ros_domain: int) -> None:
    emu = _start(['-m', 'pam_bench.cli', 'emulate', 'demo'])
    try:
        time.sleep(2.0)
        res = _check('demo')
    finally:
        _stop(emu)
    assert res.returncode == 0, res.stdout + res.stderr
    rows = _rows(res.stdout)
    assert {'/load_cell_1/force', '/encoder/joint_state', '/valve_1/pressure',
            '/valve_1/command', '/loading_servo/command'} <= set(rows)
    assert all(' pass' in r for r in rows.values()), res.stdout


@pytest.mark.parametrize('faults, expect', [
    (['slow_force', 'kn_force', 'frozen_encoder', 'gauge_pressure'],
     {'/load_cell_1/force': 'rate', '/load_cell_2/force': 'kN',
      '/encoder/joint_state': 'stamps not increasing', '/valve_1/pressure': 'gauge'}),
    (['wrong_type_encoder', 'wrong_frame'], {'/encoder/joint_state': 'std_msgs/msg/Float64',
                                             '/load_cell_1/force': "frame_id 'base_link'",
                                             '/loading_servo/state': 'not published'}),
])
def test_a_broken_driver_fails_with_its_reason(ros_domain: int, faults: list[str],
                                               expect: dict[str, str]) -> None:
    fake = _start(['-m', 'test.nodes.fake_driver', *faults])
    try:
        time.sleep(1.0)
        res = _check('servo_sin_t' if 'kn_force' in faults else 'demo')
        if 'kn_force' in faults:           # the servo's contract has no valve pressure
            res2 = _check('demo')
    finally:
        _stop(fake)
    assert res.returncode == 1, res.stdout + res.stderr
    rows = _rows(res.stdout)
    if 'kn_force' in faults:
        rows.update({k: v for k, v in _rows(res2.stdout).items() if k == '/valve_1/pressure'})
    for topic, word in expect.items():
        assert 'FAIL' in rows[topic] and word in rows[topic], rows[topic]
    # no driver subscribes to the commands
    assert 'FAIL' in rows['/valve_1/command']
