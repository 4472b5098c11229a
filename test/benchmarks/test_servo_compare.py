"""servo-compare in worker processes: the same rows as one after the other, one ROS domain per
worker."""

from __future__ import annotations

import json
import multiprocessing
import os
import pathlib

import pytest

from pam_bench.benchmarks.servo_compare import _worker_init, compare_servo, worker_domain
from pam_bench.control.torque_servo import ServoMode
from test.conftest import next_domain

TIMING = ('wall_s', 'real_time_factor')


@pytest.mark.parametrize('base, index, expected', [(5, 0, 5), (5, 1, 6), (101, 1, 0),
                                                   (0, 3, 3)])
def test_worker_domain(base: int, index: int, expected: int) -> None:
    assert worker_domain(base, index) == expected


def test_each_worker_takes_its_own_domain(monkeypatch: pytest.MonkeyPatch) -> None:
    counter = multiprocessing.get_context('spawn').Value('i', 0)
    seen = []
    for _ in range(2):
        monkeypatch.setenv('ROS_DOMAIN_ID', '0')
        _worker_init(counter, [17, 42])
        seen.append(os.environ['ROS_DOMAIN_ID'])
    assert seen == ['17', '42']
    assert os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'LOCALHOST'


def _without_timing(rows: list[dict]) -> str:
    """The rows without their timing, as text (a NaN metric then equals itself)."""
    return json.dumps([{k: v for k, v in r.items() if k not in TIMING} for r in rows],
                      sort_keys=True)


def test_two_numpy_jobs_give_the_serial_rows(tmp_path: pathlib.Path) -> None:
    serial = compare_servo(tmp_path / 'a', 'numpy', ['servo_sin_t'], duration_s=1.5)
    parallel = compare_servo(tmp_path / 'b', 'numpy', ['servo_sin_t'], duration_s=1.5, jobs=2)
    assert _without_timing(parallel) == _without_timing(serial)


def test_two_composed_jobs_run_on_their_own_domains(tmp_path: pathlib.Path,
                                                    ros_domain: int) -> None:
    """Through the composed nodes, two at once on two further domains: every controller's
    run completes and tracks as the numpy engine does (same models, same exchanges)."""
    rows = compare_servo(tmp_path, 'ros', ['servo_sin_t'], duration_s=1.5, one_process=True,
                         jobs=2, domains=[next_domain(), next_domain()])
    assert [r['controller'] for r in rows] == [m.value for m in ServoMode]
    twin = compare_servo(tmp_path / 'numpy', 'numpy', ['servo_sin_t'], duration_s=1.5)
    for r, t in zip(rows, twin, strict=True):
        assert r['sim_s'] == pytest.approx(1.5)
        assert r['rms_error'] == pytest.approx(t['rms_error'], abs=0.01)
