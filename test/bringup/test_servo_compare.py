"""servo-compare on the execution layer: the same rows on one worker as on two, one ROS domain
per worker."""

from __future__ import annotations

import json
import pathlib

import pytest

from pam_bench.bringup.servo_compare import compare_servo
from pam_bench.control.torque_servo import ServoMode
from pam_bench.vocabulary.run import Layout
from test.conftest import next_domain

TIMING = ('wall_s', 'real_time_factor')


def _without_timing(rows: list[dict]) -> str:
    """The rows without their timing, as text (a NaN metric then equals itself)."""
    return json.dumps([{k: v for k, v in r.items() if k not in TIMING} for r in rows],
                      sort_keys=True)


def test_one_and_two_workers_give_the_same_rows(tmp_path: pathlib.Path) -> None:
    one = compare_servo(tmp_path / 'a', 'twin', ['servo_sin_t'], duration_s=1.5,
                        cluster={'workers': 1})
    two = compare_servo(tmp_path / 'b', 'twin', ['servo_sin_t'], duration_s=1.5,
                        cluster={'workers': 2})
    assert _without_timing(two) == _without_timing(one)
    assert len(one) == len(ServoMode)


def test_two_composed_workers_run_on_their_own_domains(tmp_path: pathlib.Path,
                                                       ros_domain: int,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """Through the composed nodes, two at once on two further domains: every controller's
    run completes and tracks as the twin engine does (same models, same exchanges)."""
    monkeypatch.setenv('PAM_BENCH_DOMAINS', f'{next_domain()},{next_domain()}')
    rows = compare_servo(tmp_path, 'ros', ['servo_sin_t'], duration_s=1.5, layout=Layout.COMPOSED,
                         cluster={'workers': 2})
    assert [r['controller'] for r in rows] == [m.value for m in ServoMode]
    twin = compare_servo(tmp_path / 'twin', 'twin', ['servo_sin_t'], duration_s=1.5,
                         cluster={'workers': 1})
    for r, t in zip(rows, twin, strict=True):
        assert r['sim_s'] == pytest.approx(1.5)
        assert r['rms_error'] == pytest.approx(t['rms_error'], abs=0.01)


def test_sets_reach_every_run_and_a_bad_one_is_one_line(tmp_path: pathlib.Path) -> None:
    """``servo-compare --set`` as ``run --set``: the value reaches the scene each run builds,
    and an unknown setting ends the command before any run."""
    import subprocess
    import sys

    from pam_bench.bringup.servo_compare import scene_with
    scene = scene_with('servo_sin_t', (('torque_servo.servo.kp_v_per_n', 0.02),))
    assert scene.settings()['torque_servo'].servo.kp_v_per_n == 0.02
    bad = subprocess.run([sys.executable, '-m', 'pam_bench.cli', 'servo-compare', '--engine',
                          'twin', '--scene', 'servo_sin_t', '--set',
                          'torque_servo.servo.kp_vv=0.02', '--out', str(tmp_path / 'out')],
                         capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and "unknown setting 'torque_servo.servo.kp_vv'" in bad.stderr
    assert len(bad.stderr.strip().splitlines()) == 1 and not (tmp_path / 'out').exists()
