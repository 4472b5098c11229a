"""Where a resumed run starts, from a bag written without ROS."""

from __future__ import annotations

import pathlib

import pytest

from pam_bench.bags.bagwrite import write_bag
from pam_bench.bags.errors import BagError
from pam_bench.bringup.resume import resume_reading
from pam_bench.config.protocols import protocol_schedule
from pam_bench.config.scene import load_scene
from pam_bench.protocol.schedules import with_approach

SCENE = load_scene('isometric_quick')
READINGS, _ = protocol_schedule(SCENE.protocol)


def _bag(path: pathlib.Path, taken: int) -> pathlib.Path:
    points = [{'protocol': r.protocol, 'series': r.series, 'step': r.step,
               'direction': int(r.direction), 'series_value': r.series_value,
               'set_value': r.set_value, 'voltage': r.voltage_v, 'force': 1.0,
               'contraction': r.series_value, 'pressure': 1e5} for r in READINGS[:taken]]
    write_bag(path, points)
    return path


@pytest.mark.parametrize('taken', [1, 14, 20, 41, 42])
def test_resume_starts_at_the_first_reading_the_bag_lacks(tmp_path: pathlib.Path,
                                                          taken: int) -> None:
    got, total = resume_reading(SCENE, _bag(tmp_path / 'bag', taken))
    assert (got, total) == (taken, len(READINGS)) and total == 42


@pytest.mark.parametrize('index, path', [
    (0, []),                         # the protocol's start: nothing before it
    (5, list(range(0, 5))),          # in the first series: its readings before it
    (14, list(range(0, 14))),        # a series start: the whole series before
    (17, list(range(0, 17))),        # the series before, then this one's up to it
    (30, list(range(14, 30))),       # two series before: only the last one counts
])
def test_approach_walks_the_series_path(index: int, path: list[int]) -> None:
    readings, start = with_approach(READINGS, index)
    assert start == index and readings[:index] == READINGS[:index]
    approach = readings[index:index + len(path)]
    assert [(r.series, r.step) for r in approach] == \
        [(READINGS[j].series, READINGS[j].step) for j in path]
    assert all(not r.recorded and r.record_s == 0.0 for r in approach)
    assert readings[index + len(path):] == READINGS[index:]


def test_a_broken_bag_is_one_error(tmp_path: pathlib.Path) -> None:
    (tmp_path / 'bag').mkdir()
    with pytest.raises(BagError):
        resume_reading(SCENE, tmp_path / 'bag')
