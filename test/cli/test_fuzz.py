"""Fuzzing the inputs a user hands pam_bench (issue 41): scenes, sweeps, protocols, ``--set``
values and bags. Whatever hypothesis draws, every verb ends in bounded time with exit 0 or one
error line, never a traceback, and leaves its input as it was (bag-repair aside: it repairs).

The numbers of cases are the ``max_examples`` below; BENCHMARKS.md ("Fuzzing the inputs")
records them.
"""

from __future__ import annotations

import pathlib
import shutil
import time

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from test.cli.helpers import cli, one_line_error, tree_digest

CONFIG = pathlib.Path(__file__).parents[2] / 'config'
FUZZ = settings(max_examples=300, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow])
BAG_FUZZ = settings(FUZZ, max_examples=60)
TIME_BOUND_S = 20.0

_scalars = st.one_of(st.none(), st.booleans(), st.integers(-10**12, 10**12),
                     st.floats(allow_nan=True, allow_infinity=True),
                     st.text(max_size=40))
_keys = st.sampled_from(['nodes', 'exchange_step_s', 'protocol', 'description', 'parameters',
                         'protocol_overrides', 'duration_s', 'sub_step_s', 'faults',
                         'record_samples', 'dwell_s', 'kind', 'voltage_v', 'x_m', 'muscle_1',
                         'valve_1', 'sequencer', 'ros__parameters', 'up', 'n']) | st.text(
                             max_size=12)
_values = st.recursive(_scalars, lambda inner: st.lists(inner, max_size=5)
                       | st.dictionaries(_keys, inner, max_size=5), max_leaves=25)


def _ends_cleanly(code: int, err: str, ok: tuple[int, ...] = (0,)) -> None:
    if code not in ok:
        one_line_error(code, err)


def _mutated(base: dict, drop: list[str], extra: dict) -> dict:
    out = {k: v for k, v in base.items() if k not in drop}
    out.update(extra)
    return out


def _dump(path: pathlib.Path, data: object) -> None:
    try:
        text = yaml.safe_dump(data, allow_unicode=True)
    except (yaml.YAMLError, ValueError):
        text = repr(data)
    path.write_text(text, encoding='utf-8')


@FUZZ
@given(drop=st.lists(st.sampled_from(['nodes', 'exchange_step_s', 'protocol', 'parameters']),
                     max_size=2), extra=st.dictionaries(_keys, _values, max_size=3))
def test_fuzzed_scenes_end_cleanly(tmp_path: pathlib.Path, drop: list[str],
                                   extra: dict) -> None:
    base = yaml.safe_load((CONFIG / 'scenes' / 'demo.yaml').read_text())
    path = tmp_path / 'fuzz_scene.yaml'
    _dump(path, _mutated(base, drop, extra))
    before = path.read_bytes()
    t0 = time.monotonic()
    code, _, err = cli('params', path)
    assert time.monotonic() - t0 < TIME_BOUND_S
    _ends_cleanly(code, err)
    assert path.read_bytes() == before


@FUZZ
@given(text=st.text(max_size=300))
def test_fuzzed_yaml_text_ends_cleanly(tmp_path: pathlib.Path, text: str) -> None:
    path = tmp_path / 'fuzz_text.yaml'
    path.write_text(text, encoding='utf-8')
    code, _, err = cli('params', path)
    _ends_cleanly(code, err)


@FUZZ
@given(drop=st.lists(st.sampled_from(['scene', 'engine', 'seeds', 'grid', 'figures']),
                     max_size=2), extra=st.dictionaries(
                         st.sampled_from(['scene', 'engine', 'seeds', 'grid', 'list', 'random',
                                          'figures', 'duration_s']) | st.text(max_size=8),
                         _values, max_size=3))
def test_fuzzed_sweeps_are_checked_cleanly(tmp_path: pathlib.Path, drop: list[str],
                                           extra: dict) -> None:
    from pam_bench.sweep.spec import load_sweep
    from pam_bench.vocabulary.errors import PamBenchError
    base = yaml.safe_load((CONFIG / 'sweeps' / 'servo_tuning.yaml').read_text())
    path = tmp_path / 'fuzz_sweep.yaml'
    _dump(path, _mutated(base, drop, extra))
    t0 = time.monotonic()
    try:
        sweep = load_sweep(path)
    except PamBenchError as exc:
        assert str(exc) and '\n' not in str(exc).strip()
    else:
        assert len(sweep.jobs()) <= 100_000
    assert time.monotonic() - t0 < TIME_BOUND_S


@FUZZ
@given(name=st.sampled_from(['demo', 'isometric_quick', 'isotonic_quick', 'isobaric_quick',
                             'step_response_quick', 'campaign_quick']),
       overrides=st.dictionaries(
           st.sampled_from(['dwell_s', 'settle_s', 'reading_window_s', 'voltage_v', 'x_m',
                            'force_n', 'ramp_rate_v_per_s', 'reading_every_s', 'load_value',
                            'load_mode', 'up', 'down', 'record_s', 'sample_period_s', 'kind',
                            'protocols']), _values, max_size=3))
def test_fuzzed_protocol_overrides_end_cleanly(name: str, overrides: dict) -> None:
    from pam_bench.config.protocols import protocol_schedule
    from pam_bench.protocol.spec import MAX_READINGS
    from pam_bench.vocabulary.errors import PamBenchError
    t0 = time.monotonic()
    try:
        readings, _ = protocol_schedule(name, overrides)
    except PamBenchError as exc:
        assert str(exc) and '\n' not in str(exc).strip()
    else:
        assert len(readings) <= 2 * MAX_READINGS
    assert time.monotonic() - t0 < TIME_BOUND_S


@pytest.fixture(scope='module')
def demo_paths() -> list[str]:
    from pam_bench.config.scene import load_scene
    scene = load_scene('demo')
    return [f'{n}.{p}' for n, s in scene.settings().items()
            for p in _leaf_paths(type(s))][:400]


def _leaf_paths(cls: type) -> list[str]:
    from pam_bench.vocabulary.params import leaf_paths
    return leaf_paths(cls)


@FUZZ
@given(pick=st.integers(0, 10**6), value=st.text(max_size=60) | _scalars.map(str),
       mistype=st.booleans())
def test_fuzzed_set_values_end_cleanly(demo_paths: list[str], pick: int, value: str,
                                       mistype: bool) -> None:
    from pam_bench.cli.run import load_with_sets
    from pam_bench.vocabulary.errors import PamBenchError
    path = demo_paths[pick % len(demo_paths)]
    if mistype:
        path = path[:-1] + 'x'
    try:
        load_with_sets('demo', [f'{path}={value}'])
    except PamBenchError as exc:
        assert str(exc) and '\n' not in str(exc).strip()


# --- bags --------------------------------------------------------------------------------

def _chunk_spans(mcap: pathlib.Path) -> list[tuple[int, int]]:
    from mcap.reader import make_reader
    with open(mcap, 'rb') as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None
    return [(c.chunk_start_offset, c.chunk_start_offset + c.chunk_length)
            for c in summary.chunk_indexes]


def _gaps(spans: list[tuple[int, int]], size: int) -> list[tuple[int, int]]:
    """The byte ranges of a file of ``size`` bytes outside ``spans`` (sorted, disjoint)."""
    out, at = [], 0
    for a, b in sorted(spans):
        if a > at:
            out.append((at, a))
        at = max(at, b)
    return out + ([(at, size)] if at < size else [])


def _nth_byte(spans: list[tuple[int, int]], where: float) -> int:
    """The byte at share ``where`` (0 to 1) of the bytes inside ``spans``."""
    k = int(where * (sum(b - a for a, b in spans) - 1))
    for a, b in spans:
        if k < b - a:
            return a + k
        k -= b - a
    raise AssertionError('no byte in the spans')


@BAG_FUZZ
@given(how=st.sampled_from(['truncate', 'flip_in_chunk', 'flip_outside']),
       where=st.floats(0.0, 1.0), width=st.integers(1, 64))
def test_fuzzed_bags_end_cleanly(demo_bag: pathlib.Path, tmp_path: pathlib.Path, how: str,
                                 where: float, width: int) -> None:
    work = tmp_path / 'work'
    shutil.rmtree(work, ignore_errors=True)
    bag = work / 'bag'
    shutil.copytree(demo_bag, bag)
    mcap = next(bag.glob('*.mcap'))
    data = bytearray(mcap.read_bytes())
    spans = _chunk_spans(mcap)
    if how == 'truncate':
        data = data[:int(where * len(data))]
    else:
        at = _nth_byte(spans if how == 'flip_in_chunk' else _gaps(spans, len(data)), where)
        for i in range(at, min(at + width, len(data))):
            data[i] ^= 0xA5
    mcap.write_bytes(bytes(data))
    before = tree_digest(bag)
    t0 = time.monotonic()
    for args, ok in ((('info', bag), (0,)), (('diff', demo_bag, bag), (0, 1)),
                     (('extract', bag, '--out', work / 'x'), (0,))):
        code, _, err = cli(*args)
        _ends_cleanly(code, err, ok)
        assert tree_digest(bag) == before, args
    code, out, err = cli('bag-repair', bag)
    _ends_cleanly(code, err)
    if code == 0 and how != 'flip_outside':
        assert 'valid' not in out or how == 'truncate' and where > 0.999, out
    assert time.monotonic() - t0 < 4 * TIME_BOUND_S


# --- numbers as YAML 1.2 writes them, and bags of other recorders (issue 51) ---------------

_numbers = st.floats(allow_nan=False, allow_infinity=False, min_value=-1e12, max_value=1e12)


def _yaml12(value: float, form: int) -> str:
    """``value`` as a YAML 1.2 float text: an exponent without a sign or a dot, with one, or
    a plain decimal."""
    text = [f'{value:e}'.replace('e+', 'e'), f'{value:.6e}', repr(value)][form % 3]
    return text.replace('e0', 'e') if 'e0' in text and 'e0.' not in text else text


@FUZZ
@given(value=_numbers, form=st.integers(0, 2))
def test_fuzzed_yaml_1_2_numbers_read_as_floats(value: float, form: int) -> None:
    from pam_bench.vocabulary.yaml_io import load_yaml
    text = _yaml12(value, form)
    got = load_yaml(f'x: {text}', 'fuzz')['x']
    assert isinstance(got, (int, float)) and not isinstance(got, bool), (text, got)
    assert got == pytest.approx(float(text), rel=1e-15, abs=0.0), (text, got)


@FUZZ
@given(value=st.floats(min_value=0.5, max_value=20.0), form=st.integers(0, 2))
def test_fuzzed_set_numbers_in_yaml_1_2_are_taken(value: float, form: int) -> None:
    """A setting given as 2e0, 1.5e1, ...: taken as the number, or refused for its range
    with one line naming it, never as 'not a number'."""
    from pam_bench.cli.run import load_with_sets
    from pam_bench.vocabulary.errors import PamBenchError
    text = _yaml12(value, form)
    try:
        scene = load_with_sets('demo', [f'sequencer.stale_timeout_s={text}'])
    except PamBenchError as exc:
        assert 'expected a number' not in str(exc) and 'stale_timeout_s' in str(exc)
    else:
        assert scene.settings()['sequencer'].stale_timeout_s == pytest.approx(float(text))


_types = st.sampled_from([('std_msgs/msg/String', 'x'), ('std_msgs/msg/Float64', 1.5),
                          ('std_msgs/msg/Int32', 7), ('std_msgs/msg/Bool', True)])
_topics = st.sampled_from(['/chatter', '/protocol/point', '/protocol/step_response',
                           '/load_cell_1/force', '/diagnostics']) | st.from_regex(
                               r'/[a-z][a-z0-9_]{0,8}', fullmatch=True)


@BAG_FUZZ
@given(entries=st.lists(st.tuples(_topics, _types), min_size=1, max_size=3,
                        unique_by=lambda e: e[0]))
def test_fuzzed_foreign_bags_are_named_not_damaged(
        tmp_path: pathlib.Path, entries: list[tuple[str, tuple[str, object]]]) -> None:
    """A valid bag of another recorder (any topics, standard types): info reads it, extract
    refuses it as 'not a pam_bench bag' (or 'the run took no reading'), never as damaged,
    and bag-repair finds it valid."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore
    store = get_typestore(Stores.ROS2_JAZZY)
    bag = tmp_path / 'foreign'
    shutil.rmtree(bag, ignore_errors=True)
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        for topic, (msgtype, data) in entries:
            conn = w.add_connection(topic, msgtype, typestore=store)
            w.write(conn, 1, store.serialize_cdr(store.types[msgtype](data=data), msgtype))
    before = tree_digest(bag)
    assert cli('info', bag)[0] == 0
    line = one_line_error(*cli('extract', bag, '--out', tmp_path / 'report')[::2])
    assert 'not a pam_bench bag' in line or 'took no reading' in line, line
    assert 'damaged' not in line
    code, out, err = cli('bag-repair', bag)
    assert code == 0 and 'valid' in out, out + err
    assert tree_digest(bag) == before
