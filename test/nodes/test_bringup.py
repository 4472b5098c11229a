"""Bring-up: separate processes and one process, determinism, bag validity in both readers."""

from __future__ import annotations

import pathlib

import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.rosbag2 import Reader

from pam_bench.bringup.runner import run_scene
from pam_bench.config.scene import load_scene
from pam_bench.config.topics import EVENT_TOPICS, STEP_TOPICS
from pam_bench.models.muscle import MuscleModel
from pam_bench.twin.protocol_run import run_protocol
from pam_bench.vocabulary.run import Layout, RunOptions
from test.conftest import next_domain
from test.helpers import bag_messages, bag_payloads, canonical_payloads

SCENE = pathlib.Path(__file__).resolve().parents[1] / 'config_short.yaml'
# 0.5 s settle + 2 s up + 2 s down at 10 ms, and 1 ms at each new reading: the numpy twin of
# the run takes the same exchange steps as the nodes' sim clock
TWIN = run_protocol('demo_short', 0.01)
STEPS = TWIN.exchanges


@pytest.fixture(scope='module')
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, pathlib.Path]:
    out = {}
    for name, one in [('proc_a', False), ('proc_b', False), ('one', True)]:
        bag = tmp_path_factory.mktemp('bags') / name
        res = run_scene(load_scene(str(SCENE)), str(bag),
                        RunOptions(layout=Layout.COMPOSED if one else Layout.PROCESSES, seed=3,
                                   domain_id=next_domain(), quiet=True))
        assert res.code == 0, res
        assert res.steps == STEPS
        out[name] = bag
    return out


def test_every_contract_topic_recorded(runs: dict[str, pathlib.Path]) -> None:
    payloads = bag_payloads(runs['proc_a'])
    for entry in STEP_TOPICS:
        topic = entry.split(':')[0]
        assert len(payloads[topic]) >= STEPS, topic
    assert len(payloads['/protocol/point']) == 8
    with Reader(runs['proc_a']) as reader:
        topics = {c.topic for c in reader.connections}
    assert {e.split(':')[0] for e in EVENT_TOPICS} <= topics


def test_log_time_is_sim_time(runs: dict[str, pathlib.Path]) -> None:
    for topic, msgs in bag_payloads(runs['proc_a']).items():
        times = [t for t, _ in msgs]
        assert max(times) <= 5_000_000_000, topic          # sim seconds, not wall clock
    forces = bag_messages(runs['proc_a'], '/load_cell_1/force')
    stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in forces]
    assert stamps == sorted(stamps) and stamps[-1] == round(TWIN.sim_s * 1e9) == 4_500_000_000


@pytest.mark.parametrize('other', ['proc_b', 'one'])
def test_same_scene_same_seed_same_payloads(runs: dict[str, pathlib.Path], other: str) -> None:
    a, b = canonical_payloads(runs['proc_a']), canonical_payloads(runs[other])
    for topic in a:
        if topic == '/diagnostics':
            continue
        assert a[topic] == b[topic], topic


def test_mcap_ros2_decodes_everything(runs: dict[str, pathlib.Path]) -> None:
    bag = runs['proc_a']
    files = list(bag.glob('*.mcap'))
    assert len(files) == 1
    n = 0
    with open(files[0], 'rb') as fh:
        for _, _, _, decoded in make_reader(
                fh, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            assert decoded is not None
            n += 1
    assert n == sum(len(v) for v in bag_payloads(bag).values())


def test_force_follows_the_ramp(runs: dict[str, pathlib.Path]) -> None:
    pts = bag_messages(runs['proc_a'], '/protocol/point')
    peak = max(pts, key=lambda p: p.voltage)
    assert peak.voltage == pytest.approx(2.0)
    # the static force at that pressure and contraction, within the braid-friction band
    m = MuscleModel()
    expected = m.static_force(peak.pressure, peak.contraction)
    assert abs(peak.force - expected) < 0.1 * expected
    assert all(abs(p.contraction - 0.020) < 2e-4 for p in pts)
