"""The profile study's causes: where a function's own time is counted, and the table of an
earlier measurement beside the new one."""

from __future__ import annotations

import pathlib

import pytest

from benchmarks.profile import CAUSES, cause_of, section


@pytest.mark.parametrize(('filename', 'function', 'cause'), [
    ('/v/pam_bench/models/coupling.py', 'solve_substep', 'physics'),
    ('/v/pam_bench/protocol/runner.py', 'tick', 'physics'),
    ('/v/pam_bench/sim/lockstep.py', 'take', 'lock-step bookkeeping'),
    ('/v/pam_bench/runtime/intra.py', 'drain', 'lock-step bookkeeping'),
    ('/v/pam_bench/runtime/base.py', 'publish_each', 'lock-step bookkeeping'),
    ('/v/pam_bench/nodes/sim_clock.py', '_on_ack', 'lock-step bookkeeping'),
    ('/v/pam_bench/runtime/lockstep.py', 'step', 'node glue'),       # as nodes/lockstep was
    ('/v/pam_bench/runtime/stamped.py', 'stamped', 'node glue'),
    ('/v/pam_bench/nodes/valve_sim.py', 'on_step', 'node glue'),
    ('/v/site-packages/rosbags/rosbag2/storage_mcap.py', 'write', 'bag writing'),
    ('/v/site-packages/geometry_msgs/msg/_wrench.py', '__init__', 'message objects'),
    ('/v/site-packages/rclpy/executors.py', 'spin_once', 'DDS and executor'),
    ('~', "<method 'wait' of 'rclpy._rclpy_pybind11.WaitSet' objects>", 'waiting'),
    ('~', '<built-in method builtins.len>', 'other'),
])
def test_each_file_counts_under_its_cause(filename: str, function: str, cause: str) -> None:
    assert cause in CAUSES
    assert cause_of(filename, function) == cause


def _row(scene: str, layout: str, wall: float) -> dict:
    return {'scene': scene, 'layout': layout, 'wall_us_per_exchange': wall,
            'us_per_exchange': dict.fromkeys(CAUSES, 1.0)}


def test_an_earlier_row_stands_above_its_row_now() -> None:
    r = {'commit': 'bbbbbbb', 'measured': {'profile': {'commit': 'ccccccc'}},
         'profile': [_row('servo_sin_t', 'composed', 800.0), _row('campaign_quick', 'composed',
                                                                  900.0)],
         'profile_before': {'commit': 'aaaaaaa',                 # the layout's older name
                            'rows': [_row('servo_sin_t', 'one process', 1000.0)]}}
    lines = [line for line in section(r, pathlib.Path('.')) if line.startswith('| `')]
    assert [line.split(' | ')[:4] for line in lines] == [
        ['| `aaaaaaa`', 'servo_sin_t', 'composed', '1000'],
        ['| `ccccccc`', 'servo_sin_t', 'composed', '800'],
        ['| `ccccccc`', 'campaign_quick', 'composed', '900']]
