"""Quick protocol scenes end to end through separate-process nodes: counts, order, dwell."""

from __future__ import annotations

import pathlib

import numpy as np
import pytest

from pam_bench.bringup.runner import run_scene
from pam_bench.config.scene import load_scene
from pam_bench.protocol.schedules import Direction
from pam_bench.vocabulary.run import Layout, RunOptions
from test.conftest import next_domain
from test.helpers import bag_messages

HERE = pathlib.Path(__file__).resolve().parents[1]


@pytest.fixture(scope='module')
def isometric_bag(tmp_path_factory: pytest.TempPathFactory) -> pathlib.Path:
    bag = tmp_path_factory.mktemp('iso') / 'bag'
    res = run_scene(load_scene('isometric_quick'), str(bag),
                    RunOptions(domain_id=next_domain(), quiet=True))
    assert res.code == 0, res
    return bag


def test_isometric_quick_counts_order_and_dwell(isometric_bag: pathlib.Path) -> None:
    pts = bag_messages(isometric_bag, '/protocol/point')
    assert len(pts) == 3 * 14
    assert [p.series for p in pts] == [s for s in range(3) for _ in range(14)]
    assert [p.step for p in pts] == list(range(14)) * 3
    dirs = [p.direction for p in pts[:14]]
    assert dirs == [Direction.UP] * 7 + [Direction.DOWN] * 7
    np.testing.assert_allclose([p.voltage for p in pts[:14]],
                               list(range(7)) + list(range(6, -1, -1)))
    t = np.array([p.header.stamp.sec + p.header.stamp.nanosec * 1e-9 for p in pts])
    np.testing.assert_allclose(np.diff(t), 3.0, atol=1e-9)      # one reading every 3 s sim
    np.testing.assert_allclose([p.series_value for p in pts[::14]], [0.0, 0.04, 0.08])
    for p in pts:
        assert abs(p.contraction - p.series_value) < 1e-3        # held by the loading servo


def test_the_bag_keeps_the_offered_qos_of_every_topic(isometric_bag: pathlib.Path) -> None:
    """As rosbag2 does: a player can offer /protocol/status latched again."""
    import yaml
    meta = yaml.safe_load((isometric_bag / 'metadata.yaml').read_text())
    info = meta['rosbag2_bagfile_information']
    offered = {t['topic_metadata']['name']: t['topic_metadata']['offered_qos_profiles']
               for t in info['topics_with_message_count']}
    assert all(offered.values()), offered
    status = offered['/protocol/status']
    status = yaml.safe_load(status) if isinstance(status, str) else status
    assert status[0]['durability'] == 'transient_local' and status[0]['depth'] == 1
    force = offered['/load_cell_1/force']
    force = yaml.safe_load(force) if isinstance(force, str) else force
    assert force[0]['history'] == 'keep_all' and force[0]['reliability'] == 'reliable'


def test_isometric_quick_force_is_near_linear_in_u(isometric_bag: pathlib.Path) -> None:
    pts = bag_messages(isometric_bag, '/protocol/point')
    up = [p for p in pts[:7]]
    slope = np.polyfit([p.voltage for p in up[2:]], [p.force for p in up[2:]], 1)[0]
    # above the contact band the slope is k_v g_0 (316.5 N/V); 004's 284.3 N/V is the line the
    # extraction fits over the whole sweep (test/verify/test_calibration.py)
    assert 250.0 < slope < 320.0


def test_step_response_records_at_1khz(tmp_path: pathlib.Path, ros_domain: int) -> None:
    bag = tmp_path / 'bag'
    res = run_scene(load_scene(str(HERE / 'config_step.yaml')), str(bag),
                    RunOptions(domain_id=ros_domain, quiet=True))
    assert res.code == 0, res
    recs = bag_messages(bag, '/protocol/step_response')
    assert len(recs) == 2
    up, down = recs
    for r in recs:
        assert len(r.force) == 1000 and r.sample_period == pytest.approx(0.001)
        assert r.contraction == pytest.approx(0.04)
    assert (up.voltage_initial, up.voltage_final) == pytest.approx((1.0, 1.2))
    assert (down.voltage_initial, down.voltage_final) == pytest.approx((5.0, 4.8))
    f = np.array(up.force)
    assert f[-1] - f[0] > 5.0                                   # the force rose after the step
    assert f.max() > f[-1] + 0.5                                # and overshot: 2nd order (004)
    pts = bag_messages(bag, '/protocol/point')
    assert len(pts) == 2


@pytest.mark.parametrize('one_process', [False, True], ids=['processes', 'one_process'])
@pytest.mark.parametrize('name', ['config_step.yaml', 'isotonic_quick'])
def test_nodes_match_the_numpy_twin(name: str, one_process: bool, tmp_path: pathlib.Path
                                    ) -> None:
    """Nodes (separate processes, or composed on the intra-process bus) against the numpy
    twin of the same run (sequencer state machine on the numpy bench, same exchange steps),
    load-cell noise off: the same exchanges, the same readings and every 1 kHz record sample
    equal to the last bit (the muscle node solves the sub-steps with the drive's law, the
    drive replays them)."""
    import dataclasses

    from pam_bench.models.sensors import LoadCellParams
    from pam_bench.twin.protocol_run import run_protocol
    scene = load_scene(str(HERE / name) if name.endswith('.yaml') else name)
    quiet = dataclasses.replace(scene, parameters={'load_cell_1': {'load_cell':
                                                                   {'noise': False}}})
    bag = tmp_path / 'bag'
    res = run_scene(quiet, str(bag),
                    RunOptions(layout=Layout.COMPOSED if one_process else Layout.PROCESSES,
                               domain_id=next_domain(), quiet=True))
    assert res.code == 0, res
    twin = run_protocol(scene.protocol, scene.exchange_step_s,
                        overrides=scene.protocol_overrides, sub_step_s=scene.sub_step_s,
                        load_cell=LoadCellParams(noise=False))
    assert res.steps == twin.exchanges
    pts = bag_messages(bag, '/protocol/point')
    assert [p.force for p in pts] == [q.measurement.force_n for q in twin.points]
    assert [p.contraction for p in pts] == [q.measurement.contraction_m for q in twin.points]
    recs = bag_messages(bag, '/protocol/step_response')
    assert len(recs) == len(twin.records)
    for a, b in zip(recs, twin.records, strict=True):
        assert list(a.force) == list(b.samples)
    if recs:                                   # every sample of a record is in the bag
        cell = bag_messages(bag, '/load_cell_1/force')
        t0 = recs[0].header.stamp.sec * 10**9 + recs[0].header.stamp.nanosec
        stamps = np.array([m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in cell])
        window = stamps[(stamps >= t0) & (stamps < t0 + 10**9)]
        np.testing.assert_array_equal(np.diff(window), 1_000_000)
        assert len(window) == 1000


def test_a_law_on_the_demo_runs_as_the_twin_runs_it(tmp_path: pathlib.Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    """A force law left to ``auto``: the scene runs it as written on the demo's 10 ms
    exchanges, and the twin of the same steps decides the same (``law_core_for``), so the
    nodes' readings are the twin's to the last bit."""
    import dataclasses

    from pam_bench.models.sensors import LoadCellParams
    from pam_bench.twin import protocol_run
    from pam_bench.twin.protocol_run import run_protocol
    built = []
    bench = protocol_run.SingleMuscleBench
    monkeypatch.setattr(protocol_run, 'SingleMuscleBench',
                        lambda **kw: built.append(kw['muscle'].law_core) or bench(**kw))
    scene = load_scene('demo')
    law = {'kind': 'law', 'law': 'bench_mckibben'}       # the bench's law, through the zoo
    quiet = dataclasses.replace(scene, parameters={
        'load_cell_1': {'load_cell': {'noise': False}}, 'muscle_1': {'muscle': law}})
    assert quiet.settings()['muscle_1'].muscle.law_core == 'interpreted'
    bag = tmp_path / 'bag'
    res = run_scene(quiet, str(bag), RunOptions(layout=Layout.COMPOSED,
                                                domain_id=next_domain(), quiet=True))
    assert res.code == 0, res
    twin = run_protocol(scene.protocol, scene.exchange_step_s,
                        overrides=scene.protocol_overrides, sub_step_s=scene.sub_step_s,
                        load_cell=LoadCellParams(noise=False),
                        muscle=quiet.settings()['muscle_1'].muscle.__class__(**law))
    assert built == ['interpreted']
    pts = bag_messages(bag, '/protocol/point')
    assert len(pts) == len(twin.points) == 24
    assert [p.force for p in pts] == [q.measurement.force_n for q in twin.points]
    assert [p.contraction for p in pts] == [q.measurement.contraction_m for q in twin.points]


def test_resume_after_an_interrupted_run(tmp_path: pathlib.Path) -> None:
    """A run cut short (the clock stops at 60 s of a 129 s protocol) leaves a valid bag; the
    resumed run starts at the first reading the bag lacks and takes the rest: nothing twice,
    and each resumed reading close to the uninterrupted run's."""
    import dataclasses

    from pam_bench.bringup.resume import resume_reading
    scene = load_scene('isometric_quick')
    first = tmp_path / 'first'
    res = run_scene(dataclasses.replace(scene, duration_s=60.0), str(first),
                    RunOptions(domain_id=next_domain(), quiet=True))
    assert res.code == 0, res
    taken = bag_messages(first, '/protocol/point')
    start, total = resume_reading(scene, first)
    assert 0 < len(taken) < total and start <= len(taken)
    assert start == len(taken)                   # reading-precise: nothing redone
    resumed = dataclasses.replace(scene, parameters={'sequencer': {'resume_from_reading':
                                                                   start}})
    second = tmp_path / 'second'
    res = run_scene(resumed, str(second), RunOptions(domain_id=next_domain(), quiet=True))
    assert res.code == 0, res
    rest = bag_messages(second, '/protocol/point')
    assert len(rest) == total - start
    assert (rest[0].series, rest[0].step) == (start // 14, start % 14)
    keys = {(p.series, p.step) for p in taken}
    assert not keys & {(p.series, p.step) for p in rest}
    whole = tmp_path / 'whole'                  # the uninterrupted run, same seed
    assert run_scene(scene, str(whole), RunOptions(layout=Layout.COMPOSED, quiet=True)).code == 0
    ref = {(p.series, p.step): p for p in bag_messages(whole, '/protocol/point')}
    worst_n = max(abs(p.force - ref[(p.series, p.step)].force) for p in rest)
    worst_m = max(abs(p.contraction - ref[(p.series, p.step)].contraction) for p in rest)
    print(f'resumed against uninterrupted: {worst_n:.3f} N, {worst_m * 1e3:.4f} mm')
    assert worst_n < 4.0 and worst_m < 0.32e-3     # 0.2 % FS, 0.32 mm (issue 17's bounds)


@pytest.fixture(scope='module')
def campaign_quick_points(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """The readings of one uninterrupted campaign_quick (seed 0): (protocol, series, step) ->
    point."""
    bag = tmp_path_factory.mktemp('whole') / 'bag'
    assert run_scene(load_scene('campaign_quick'), str(bag),
                     RunOptions(domain_id=next_domain(), quiet=True)).code == 0
    return {(p.protocol, p.series, p.step): p for p in bag_messages(bag, '/protocol/point')}


@pytest.mark.parametrize('start', range(10, 156, 10))
def test_campaign_quick_resumes_at_every_tenth_reading(tmp_path: pathlib.Path, start: int,
                                                       campaign_quick_points: dict) -> None:
    """Cut at any reading, the campaign goes on: the loading servo is taken back along the
    series' path (not across it), and every resumed reading lands on the uninterrupted run's
    (issue 17's bounds)."""
    import dataclasses
    scene = load_scene('campaign_quick')
    resumed = dataclasses.replace(scene, parameters={
        **scene.parameters, 'sequencer': {**scene.parameters.get('sequencer', {}),
                                          'resume_from_reading': start}})
    bag = tmp_path / 'resumed'
    res = run_scene(resumed, str(bag), RunOptions(domain_id=next_domain(), quiet=True))
    assert res.code == 0, res.summary
    rest = bag_messages(bag, '/protocol/point')
    assert len(rest) == len(campaign_quick_points) - start
    ref = campaign_quick_points
    worst_n = max(abs(p.force - ref[(p.protocol, p.series, p.step)].force) for p in rest)
    worst_m = max(abs(p.contraction - ref[(p.protocol, p.series, p.step)].contraction)
                  for p in rest)
    assert worst_n < 4.0 and worst_m < 0.32e-3, (worst_n, worst_m)


def test_composed_record_samples_in_blocks_write_the_bag_of_the_messages(
        tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Composed, a load cell sends a 1 kHz record's samples as one block per exchange
    (``ForceSamples``); the bag holds the same bytes as when it sends them as messages (the
    plain path, forced by saying no subscription takes blocks)."""
    from rosbags.rosbag2 import Reader

    from pam_bench.runtime import intra

    def every_message(bag: pathlib.Path) -> list[tuple[str, int, bytes]]:
        with Reader(bag) as reader:
            return [(c.topic, t, bytes(raw)) for c, t, raw in reader.messages()]

    scene = load_scene(str(HERE / 'config_step.yaml'))
    blocks = []
    taken = intra.BusPublisher.blocks_taken

    def counted(self: intra.BusPublisher) -> bool:
        ok = taken(self)
        blocks.append(ok)
        return ok

    monkeypatch.setattr(intra.BusPublisher, 'blocks_taken', counted)
    for name in ('blocks', 'messages'):
        res = run_scene(scene, str(tmp_path / name),
                        RunOptions(layout=Layout.COMPOSED, domain_id=next_domain(), quiet=True))
        assert res.code == 0, res
        monkeypatch.setattr(intra.BusPublisher, 'blocks_taken', lambda self: False)
    assert blocks and all(blocks)                       # the first run sent every record so
    with_blocks, plain = every_message(tmp_path / 'blocks'), every_message(tmp_path / 'messages')
    assert sum(t == '/load_cell_1/force' for t, _, _ in plain) > 2000
    assert with_blocks == plain
