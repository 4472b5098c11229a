"""Where a resumed run starts, from a bag written without ROS."""

from __future__ import annotations

import pathlib

import pytest

from pam_bench.analysis.bagread import BagError
from pam_bench.analysis.bagwrite import write_bag
from pam_bench.bringup.resume import resume_reading
from pam_bench.config.protocols import protocol_schedule
from pam_bench.config.scene import load_scene

SCENE = load_scene('isometric_quick')
READINGS, _ = protocol_schedule(SCENE.protocol)


def _bag(path: pathlib.Path, taken: int) -> pathlib.Path:
    points = [{'protocol': r.protocol, 'series': r.series, 'step': r.step,
               'direction': int(r.direction), 'series_value': r.series_value,
               'set_value': r.set_value, 'voltage': r.voltage_v, 'force': 1.0,
               'contraction': r.series_value, 'pressure': 1e5} for r in READINGS[:taken]]
    write_bag(path, points)
    return path


@pytest.mark.parametrize('taken, start', [
    (1, 0),            # one reading of the first series: that series again
    (14, 14),          # the first series complete: the second from its start
    (20, 14),          # part of the second: the second again
    (42, 42),          # everything: nothing left
])
def test_resume_starts_at_the_first_incomplete_series(tmp_path: pathlib.Path, taken: int,
                                                      start: int) -> None:
    got, total = resume_reading(SCENE, _bag(tmp_path / 'bag', taken))
    assert (got, total) == (start, len(READINGS)) and total == 42


def test_a_broken_bag_is_one_error(tmp_path: pathlib.Path) -> None:
    (tmp_path / 'bag').mkdir()
    with pytest.raises(BagError):
        resume_reading(SCENE, tmp_path / 'bag')
