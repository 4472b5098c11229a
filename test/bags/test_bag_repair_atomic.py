"""bag-repair is atomic and knows a live bag (issue 51): a bag being written is refused, a
repair interrupted or failing at any moment leaves a bag the next repair repairs, and what is
not a ROS 2 bag is refused in one line, unchanged."""

from __future__ import annotations

import errno
import pathlib
import shutil

import pytest

from pam_bench.bags import bag_repair
from pam_bench.bags.bag_repair import repair_bag
from pam_bench.bags.bagread import open_bag, read_bags
from pam_bench.bags.errors import BagError
from pam_bench.bags.splitwriter import SplitWriter, bag_in_use
from pam_bench.vocabulary.outputs import MARKER
from test.cli.helpers import tree_digest

SHARES = (2 / 3, 1 / 2, 2 / 5, 1 / 3, 1 / 4)
"""Where a tear may fall (share of the file kept): the first that loses some readings."""
_share: dict[pathlib.Path, float] = {}


def _tear(demo_bag: pathlib.Path, where: pathlib.Path, share: float) -> pathlib.Path:
    bag = pathlib.Path(shutil.copytree(demo_bag, where))
    (bag / 'metadata.yaml').unlink()
    mcap = next(bag.glob('*.mcap'))
    data = mcap.read_bytes()
    mcap.write_bytes(data[:int(len(data) * share)])
    return bag


def _torn(demo_bag: pathlib.Path, where: pathlib.Path) -> pathlib.Path:
    """A copy of the demo bag as a killed recorder leaves it: no metadata, its file torn where
    a repair keeps some of its readings but not all (``repaired_points`` finds where: the
    recorder's chunks fall by wall time, so a loaded machine lays the file out otherwise)."""
    return _tear(demo_bag, where, _share.get(demo_bag, SHARES[0]))


def _points(bag: pathlib.Path) -> int:
    """The readings of ``bag`` (0 when a tear kept none: then it is no pam_bench bag)."""
    try:
        return sum(len(p) for p in read_bags([bag]).points.values())
    except BagError:
        return 0


@pytest.fixture(scope='module')
def demo_bag(tmp_path_factory: pytest.TempPathFactory) -> pathlib.Path:
    """The demo's bag in many chunks (the recorder closes one every 20 ms of wall time), so
    that a tear in the file keeps some of its readings and loses others whatever the machine's
    load: with the default second, the run of about 0.4 s was one or two chunks, and a loaded
    machine once laid the file out so that no tear kept some but not all."""
    from test.cli.helpers import cli
    from test.conftest import next_domain
    bag = tmp_path_factory.mktemp('chunked') / 'demo_bag'
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv('ROS_DOMAIN_ID', str(next_domain()))
        code, out, err = cli('run', 'demo', '--out', bag, '--set',
                             'recorder.flush_period_s=0.02')
    assert code == 0, out + err
    return bag


@pytest.fixture
def repaired_points(demo_bag: pathlib.Path, tmp_path: pathlib.Path) -> int:
    """How many readings a repair of the torn demo bag keeps, undisturbed (the tear moved
    earlier until it loses some)."""
    total = _points(demo_bag)
    for k, share in enumerate(SHARES):
        bag = _tear(demo_bag, tmp_path / f'reference{k}', share)
        repair_bag(bag)
        n = _points(bag)
        shutil.rmtree(bag)
        shutil.rmtree(tmp_path / f'reference{k}.broken')
        if 0 < n < total:
            _share[demo_bag] = share
            return n
    raise AssertionError(f'no tear in {SHARES} keeps some of the {total} readings')


def test_a_bag_being_written_is_refused(tmp_path: pathlib.Path) -> None:
    w = SplitWriter(tmp_path / 'live')
    w.open()
    try:
        assert bag_in_use(tmp_path / 'live')
        before = tree_digest(tmp_path / 'live')
        with pytest.raises(BagError, match='being written'):
            repair_bag(tmp_path / 'live')
        with pytest.raises(BagError, match='being written'):    # info and extract say so
            open_bag(tmp_path / 'live')
        assert tree_digest(tmp_path / 'live') == before
    finally:
        w.close()
    assert not bag_in_use(tmp_path / 'live')


@pytest.mark.parametrize('where', ['_build', '_exchange'])
def test_a_failed_repair_leaves_the_bag_as_it_was(demo_bag: pathlib.Path,
                                                   tmp_path: pathlib.Path,
                                                   monkeypatch: pytest.MonkeyPatch,
                                                   where: str, repaired_points: int) -> None:
    """A file-size limit while it writes, or a signal just before the swap: nothing moved."""
    bag = _torn(demo_bag, tmp_path / 'bag')
    before = tree_digest(bag)
    real = getattr(bag_repair, where)

    def fail(*args: object) -> None:
        if where == '_build':
            raise OSError(errno.EFBIG, 'File too large')
        raise KeyboardInterrupt
    monkeypatch.setattr(bag_repair, where, fail)
    with pytest.raises((OSError, KeyboardInterrupt)):
        repair_bag(bag)
    assert tree_digest(bag) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ['bag']     # no stage left
    monkeypatch.setattr(bag_repair, where, real)
    report = repair_bag(bag)
    assert report.needed and _points(bag) == repaired_points


def test_a_repair_stopped_after_its_swap_is_finished_by_the_next(
        demo_bag: pathlib.Path, tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch,
        repaired_points: int) -> None:
    bag = _torn(demo_bag, tmp_path / 'bag')
    torn = {p.name: p.read_bytes() for p in bag.iterdir() if p.is_file() and p.name != MARKER}

    def killed(folder: pathlib.Path, broken: pathlib.Path) -> None:
        raise KeyboardInterrupt
    monkeypatch.setattr(bag_repair, '_keep_originals', killed)
    with pytest.raises(KeyboardInterrupt):
        repair_bag(bag)
    assert _points(bag) == repaired_points     # the bag is the repaired one already
    monkeypatch.undo()
    assert not repair_bag(bag).needed
    broken = tmp_path / 'bag.broken'            # the originals, whole, under their name
    assert {p.name: p.read_bytes() for p in broken.iterdir()
            if p.is_file() and p.name in torn} == torn
    assert not list(tmp_path.glob('.bag.repair-*'))


def test_the_originals_are_kept_whole_and_protected(demo_bag: pathlib.Path,
                                                    tmp_path: pathlib.Path) -> None:
    from test.cli.helpers import cli, one_line_error
    bag = _torn(demo_bag, tmp_path / 'bag')
    torn = {p.name: p.read_bytes() for p in bag.iterdir() if p.is_file() and p.name != MARKER}
    report = repair_bag(bag)
    assert report.broken_copy == tmp_path / 'bag.broken'
    assert {p.name: p.read_bytes() for p in report.broken_copy.iterdir()
            if p.name in torn} == torn
    before = tree_digest(report.broken_copy)        # no run's --overwrite takes them
    line = one_line_error(*cli('run', 'demo', '--out', report.broken_copy,
                               '--overwrite')[::2])
    assert 'bag-repair' in line and tree_digest(report.broken_copy) == before


def _json_mcap(path: pathlib.Path) -> None:
    from mcap.writer import Writer
    path.mkdir()
    with open(path / 'thing.mcap', 'wb') as fh:
        w = Writer(fh)
        w.start()
        schema = w.register_schema('thing', 'jsonschema', b'{"type": "object"}')
        channel = w.register_channel('/thing', 'json', schema)
        w.add_message(channel, log_time=1, data=b'{"a": 1}', publish_time=1)
        w.finish()


def test_what_is_not_a_ros2_bag_is_refused_unchanged(tmp_path: pathlib.Path,
                                                     demo_bag: pathlib.Path) -> None:
    bag = tmp_path / 'json'
    _json_mcap(bag)
    before = tree_digest(bag)
    with pytest.raises(BagError, match=r"not a ROS 2 bag: thing.mcap holds the schema "
                       r"'thing' as 'jsonschema'"):
        repair_bag(bag)
    assert tree_digest(bag) == before and sorted(p.name for p in tmp_path.iterdir()) == \
        ['json']
    future = pathlib.Path(shutil.copytree(demo_bag, tmp_path / 'future'))
    meta = future / 'metadata.yaml'
    meta.write_text(meta.read_text().replace('version: 9', 'version: 42', 1))
    with pytest.raises(BagError, match='rosbag2 version 42; bag-repair knows versions 1 to 9'):
        repair_bag(future)


def test_a_bag_of_an_empty_file_is_not_moved(tmp_path: pathlib.Path) -> None:
    bag = tmp_path / 'empty'
    bag.mkdir()
    (bag / 'empty.mcap').write_bytes(b'')
    with pytest.raises(BagError, match='no complete message in empty.mcap'):
        repair_bag(bag)
    assert (bag / 'empty.mcap').exists() and sorted(p.name for p in tmp_path.iterdir()) == \
        ['empty']
