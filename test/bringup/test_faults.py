"""Faults as scene entries, on the wall clock: each kind detected (the reason on
protocol/status), the bench brought to a safe state, the bag valid, every reading taken before
the fault present, and the run either survived (suspended and resumed by itself, every reading
taken) or resumable (aborted; `--resume` takes the rest)."""

from __future__ import annotations

import dataclasses
import pathlib
from typing import Any

import pytest

from benchmarks.faults import CASES, READINGS, SCENE
from pam_bench.bags.baginfo import bag_info
from pam_bench.bringup.runner import run_scene
from pam_bench.config.scene import Scene, load_scene
from pam_bench.vocabulary.run import Layout, RunOptions
from test.conftest import next_domain
from test.helpers import bag_messages

pytestmark = pytest.mark.wallclock


@pytest.fixture(scope='module')
def clean_readings(tmp_path_factory: pytest.TempPathFactory) -> dict[tuple[int, int], Any]:
    """The readings of the fault scene without its fault, in lock-step: (series, step) ->
    ProtocolPoint. Every case's scene differs only in its fault, so one run serves them all."""
    path = tmp_path_factory.mktemp('clean')
    scene = dataclasses.replace(load_scene_text(SCENE.format(fault=CASES['sensor_drift'][0]),
                                                path / 'clean.yaml'), faults=[])
    res = run_scene(scene, str(path / 'lock'),
                    RunOptions(layout=Layout.COMPOSED, quiet=True, domain_id=next_domain()))
    assert res.code == 0, res.summary
    return {(p.series, p.step): p for p in bag_messages(path / 'lock', '/protocol/point')}


def load_scene_text(text: str, path: pathlib.Path) -> Scene:
    path.write_text(text)
    return load_scene(str(path))


@pytest.mark.parametrize('kind', list(CASES))
def test_an_injected_fault_is_detected_and_survived_or_resumable(
        tmp_path: pathlib.Path, ros_domain: int, kind: str,
        clean_readings: dict[tuple[int, int], Any]) -> None:
    fault, survives, words = CASES[kind]
    scene = load_scene_text(SCENE.format(fault=fault), tmp_path / f'{kind}.yaml')
    assert scene.faults and scene.faults[0].kind == kind
    res = run_scene(scene, str(tmp_path / 'bag'), RunOptions(layout=Layout.WALL_CLOCK, quiet=True))
    bag = tmp_path / 'bag'
    status = bag_messages(bag, '/protocol/status')
    points = bag_messages(bag, '/protocol/point')
    info = bag_info(bag)                                  # the bag is valid and says how it ended
    ref = clean_readings                                  # every reading taken is unchanged
    for p in points:
        assert abs(p.force - ref[(p.series, p.step)].force) < 10.0            # 0.5 % FS
        assert abs(p.contraction - ref[(p.series, p.step)].contraction) < 0.2e-3
    if survives:
        assert res.code == 0, res.summary
        assert len(points) == READINGS                    # nothing lost
        if words:
            paused = [s for s in status if s.phase == 'paused']
            assert paused and words in paused[0].reason, [s.reason for s in status]
            assert status[-1].state == 2                  # done after the resume
        assert info['end']['state'] == 'done'
    else:
        assert res.code == 4, res.summary
        aborted = [s for s in status if s.state == 3]
        assert aborted and words in aborted[-1].reason, [s.reason for s in status]
        assert 1 <= len(points) < READINGS                # the readings before are kept
        cmds = bag_messages(bag, '/loading_servo/command')
        assert cmds[-1].mode == 0                         # safe: drive off, valve vented
        assert bag_messages(bag, '/valve_1/command')[-1].voltage == 0.0
        assert info['end']['state'] == 'aborted'


def test_faults_need_the_wall_clock(tmp_path: pathlib.Path) -> None:
    path = tmp_path / 'f.yaml'
    path.write_text(SCENE.format(fault=CASES['sensor_drift'][0]))
    with pytest.raises(ValueError, match='wall clock'):
        run_scene(load_scene(str(path)), str(tmp_path / 'bag'))


@pytest.mark.parametrize('fault, words', [
    ('{kind: sensor_drfit, target: load_cell_1, at_s: 1.0}', 'kind'),
    ('{kind: sensor_drift, target: sequencer, at_s: 1.0}', 'sensor'),
    ('{kind: valve_stuck, target: encoder, at_s: 1.0}', 'valve'),
    ('{kind: sensor_drift, target: load_cell_1, at: 1.0}', "'at'"),
])
def test_a_bad_fault_entry_is_one_clear_error(tmp_path: pathlib.Path, fault: str,
                                              words: str) -> None:
    from pam_bench.config.errors import ConfigError
    path = tmp_path / 'f.yaml'
    path.write_text(SCENE.format(fault=fault))
    with pytest.raises(ConfigError, match=words):
        load_scene(str(path))
