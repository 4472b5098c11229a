"""Issue 41's cases, as a user meets them: every bad input is one line, nothing is lost.

Each test names its case of the issue (data lost, hangs, tracebacks, silently wrong) and
checks the outcome a user sees: the exit code, one line on stderr, and that the files that
were there are still there, byte for byte.
"""

from __future__ import annotations

import pathlib
import time

import pytest

from test.cli.helpers import cli, one_line_error, tree_digest


def _copy(bag: pathlib.Path, dst: pathlib.Path) -> pathlib.Path:
    import shutil
    shutil.copytree(bag, dst)
    return dst


# --- data lost --------------------------------------------------------------------------

def test_extract_into_the_bag_folder_is_refused(demo_bag: pathlib.Path,
                                                tmp_path: pathlib.Path) -> None:
    bag = _copy(demo_bag, tmp_path / 'bag')
    before = tree_digest(bag)
    for out in (bag, bag / 'report'):
        for extra in ((), ('--overwrite',)):
            line = one_line_error(*cli('extract', bag, '--out', out, *extra)[::2])
            assert 'input' in line or 'bag' in line, line
    assert tree_digest(bag) == before


def test_extract_never_deletes_a_file_it_did_not_write(demo_bag: pathlib.Path,
                                                       tmp_path: pathlib.Path) -> None:
    mine = tmp_path / 'reports'
    mine.mkdir()
    (mine / 'notes.txt').write_text('my notes')
    (mine / 'sub').mkdir()
    (mine / 'sub' / 'data.csv').write_text('1,2')
    before = tree_digest(mine)
    for extra in ((), ('--overwrite',)):
        line = one_line_error(*cli('extract', demo_bag, '--out', mine, *extra)[::2])
        assert 'not written by pam-bench' in line, line
    assert tree_digest(mine) == before
    out = tmp_path / 'rep'
    assert cli('extract', demo_bag, '--out', out)[0] == 0
    line = one_line_error(*cli('extract', demo_bag, '--out', out)[::2])
    assert '--overwrite' in line
    (out / 'mine.txt').write_text('keep me')
    line = one_line_error(*cli('extract', demo_bag, '--out', out, '--overwrite')[::2])
    assert 'mine.txt' in line and (out / 'mine.txt').read_text() == 'keep me'
    (out / 'mine.txt').unlink()
    assert cli('extract', demo_bag, '--out', out, '--overwrite')[0] == 0


def test_run_overwrite_never_wipes_a_folder_that_is_not_its_bag(tmp_path: pathlib.Path) -> None:
    folder = tmp_path / 'thesis'
    (folder / 'chapter').mkdir(parents=True)
    (folder / 'chapter' / 'a.tex').write_text('text')
    before = tree_digest(folder)
    line = one_line_error(*cli('run', 'demo', '--out', folder, '--overwrite')[::2])
    assert 'not written by pam-bench' in line
    assert tree_digest(folder) == before


@pytest.mark.parametrize('args, words', [
    (['--wallclock', '--buses', 'no_such_map'], 'no_such_map.yaml'),
    (['--buses'], 'add --wallclock'),
    (['--namespace', '/bench_a'], 'add --wallclock'),
])
def test_run_checks_its_bus_options_before_it_touches_the_bag(
        demo_bag: pathlib.Path, tmp_path: pathlib.Path, args: list[str], words: str) -> None:
    bag = _copy(demo_bag, tmp_path / 'bag')
    before = tree_digest(bag)
    line = one_line_error(*cli('run', 'demo', '--out', bag, '--overwrite', *args)[::2])
    assert words in line and tree_digest(bag) == before


@pytest.mark.parametrize('override, words', [
    ('ramp_rate_v_per_s: 0', ['ramp_rate_v_per_s', 'minimum']),
    ('ramp_rate_v_per_s: .nan', ['ramp_rate_v_per_s', 'finite']),
    ('dwell_s: -1', ['dwell_s', 'minimum']),
    ("dwell_s: 'three'", ['dwell_s', 'number']),
    ('voltage_v: [0, 1.0e+9, 0]', ['voltage_v', 'maximum']),
    ('reading_every_s: 1e-9', ['reading_every_s']),
])
def test_a_bad_protocol_value_is_refused_before_the_old_bag_is_touched(
        demo_bag: pathlib.Path, tmp_path: pathlib.Path, override: str,
        words: list[str]) -> None:
    bag = _copy(demo_bag, tmp_path / 'bag')
    before = tree_digest(bag)
    scene = tmp_path / 'demo_bad.yaml'
    scene.write_text((pathlib.Path(__file__).parents[2] / 'config' / 'scenes' / 'demo.yaml')
                     .read_text() + f'\nprotocol_overrides: {{{override}}}\n')
    line = one_line_error(*cli('run', scene, '--out', bag, '--overwrite')[::2])
    for w in words:
        assert w in line, line
    assert tree_digest(bag) == before


def test_bag_repair_keeps_the_run_description_and_the_old_metadata(
        demo_bag: pathlib.Path, tmp_path: pathlib.Path) -> None:
    from pam_bench.bags.bag_repair import OLD_METADATA
    from pam_bench.bags.baginfo import run_of_bag
    bag = _copy(demo_bag, tmp_path / 'bag')
    old_meta = (bag / 'metadata.yaml').read_text()
    _damage_a_chunk(next(bag.glob('*.mcap')))
    code, out, err = cli('bag-repair', bag)
    assert code == 0 and 'damaged' in out, out + err
    assert (bag / OLD_METADATA).read_text() == old_meta
    assert run_of_bag(bag)['scene'] == 'demo'
    code, out, err = cli('run', '--replay', bag, '--out', tmp_path / 'again')
    assert code == 0, out + err


def _damage_a_chunk(mcap: pathlib.Path) -> int:
    """Flip a byte in the middle of the first chunk's compressed records; its offset."""
    from mcap.reader import make_reader
    with open(mcap, 'rb') as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None and summary.chunk_indexes
    idx = summary.chunk_indexes[0]
    at = idx.chunk_start_offset + idx.chunk_length // 2
    data = bytearray(mcap.read_bytes())
    data[at] ^= 0xFF
    mcap.write_bytes(bytes(data))
    return at


# --- hangs -------------------------------------------------------------------------------

_BOMB = ('a: &a ["x","x","x","x","x","x","x","x","x"]\n'
         + ''.join(f'{c}: &{c} [' + ','.join(['*' + p] * 9) + ']\n'
                   for p, c in zip('abcdefgh', 'bcdefghi', strict=True)))


def test_an_alias_bomb_is_refused_at_once(tmp_path: pathlib.Path) -> None:
    scene = tmp_path / 'bomb.yaml'
    scene.write_text('nodes: [valve_1]\nexchange_step_s: 1.0\ndescription: *i\n' + _BOMB)
    t0 = time.monotonic()
    line = one_line_error(*cli('run', scene, '--out', tmp_path / 'x')[::2])
    assert 'expand' in line or 'alias' in line, line
    flow = '{' + ', '.join(_BOMB.strip().split('\n')) + '}'      # the same bomb on one line
    line = one_line_error(*cli('run', 'demo', '--out', tmp_path / 'y', '--set',
                               'muscle_1.muscle.gain_exponent=' + flow)[::2])
    assert 'expand' in line and len(line) < 300, line
    assert time.monotonic() - t0 < 20
    assert not (tmp_path / 'x').exists() and not (tmp_path / 'y').exists()


@pytest.mark.parametrize('text', [
    'nodes: [valve_1]\nexchange_step_s: 1.0\ndescription: "' + 'x' * 50_000_000 + '"\n',
    ''.join(f'k{i}: {i}\n' for i in range(1_500_000)),
])
def test_a_huge_yaml_file_is_refused_at_once(tmp_path: pathlib.Path, text: str) -> None:
    scene = tmp_path / 'huge.yaml'
    scene.write_text(text)
    t0 = time.monotonic()
    line = one_line_error(*cli('params', scene)[::2])
    assert 'at most' in line, line
    assert time.monotonic() - t0 < 5


@pytest.mark.parametrize('value', ['nan', '-1', 'inf', '1e9', 'three'])
def test_check_drivers_duration_is_bounded(value: str) -> None:
    line = one_line_error(*cli('check-drivers', '--duration', value)[::2])
    assert '--duration' in line


# --- tracebacks --------------------------------------------------------------------------

@pytest.mark.parametrize('verb', ['scene', 'params', 'sweep'])
def test_a_file_that_is_not_utf8_is_one_line(tmp_path: pathlib.Path, verb: str) -> None:
    bad = tmp_path / 'latin1.yaml'
    bad.write_bytes('description: "Messung bei 20 \u00b0C"\n'.encode('latin-1'))
    args = {'scene': ('params', bad), 'params': ('run', 'demo', '--params', bad, '--out',
                                                  tmp_path / 'o'),
            'sweep': ('sweep', bad, '--out', tmp_path / 's')}[verb]
    line = one_line_error(*cli(*args)[::2])
    assert 'UTF-8' in line, line


def test_a_malformed_scheduler_is_one_line(demo_bag: pathlib.Path,
                                           tmp_path: pathlib.Path) -> None:
    line = one_line_error(*cli('extract', demo_bag, '--each', '--out', tmp_path / 'e',
                               '--scheduler', 'bogus::addr')[::2])
    assert 'scheduler' in line
    assert not (tmp_path / 'e').exists()


def test_an_unreachable_scheduler_is_one_line() -> None:
    from pam_bench.cli.errors import exit_code
    from pam_bench.cluster.errors import ClusterError
    assert exit_code(ClusterError('cannot reach the scheduler at tcp://127.0.0.1:1')) == 2


def test_out_on_a_pseudo_file_system_is_one_line() -> None:
    line = one_line_error(*cli('run', 'demo', '--out', '/proc/pam_bench_bag')[::2])
    assert 'pseudo-file system' in line or 'writable' in line, line


# --- silently wrong ----------------------------------------------------------------------

def _sweep(tmp_path: pathlib.Path, scene: str, figures: list[str]) -> pathlib.Path:
    path = tmp_path / 'sw.yaml'
    path.write_text(f'scene: {scene}\nengine: twin\nseeds: [0]\n'
                    'list: [{valve_1.valve.gain_pa_per_v: 100000.0}]\n'
                    f'figures: [{", ".join(figures)}]\n')
    return path


@pytest.mark.parametrize('figure, near', [
    ('servo.rms_eror', 'servo.rms_error'),
    ('isometric.gain_N_per_V.mx', 'isometric.gain_N_per_V.max'),
    ('step_response.fits.0.bb', 'step_response.fits.0.b'),
])
def test_a_misspelt_figure_is_named_before_any_job(tmp_path: pathlib.Path, figure: str,
                                                   near: str) -> None:
    line = one_line_error(*cli('sweep', _sweep(tmp_path, 'servo_sin_t', [figure]), '--out',
                               tmp_path / 'out')[::2])
    assert figure in line and near in line, line
    assert not (tmp_path / 'out').exists()


def test_a_figure_the_run_does_not_give_is_not_ok(tmp_path: pathlib.Path) -> None:
    from pam_bench.sweep.results import NO_FIGURE
    sweep = _sweep(tmp_path, 'isometric_quick',
                   ['isometric.gain_N_per_V.max', 'isotonic.gain_mm_per_V.max'])
    code, out, err = cli('sweep', sweep, '--out', tmp_path / 'out', '--no-plots',
                         '--workers', '1')
    assert code == 1, out + err
    text = (tmp_path / 'out' / 'results.csv').read_text()
    assert NO_FIGURE + 'isotonic.gain_mm_per_V.max' in text and ',ok,' not in text


def test_a_duplicate_yaml_key_is_named(tmp_path: pathlib.Path) -> None:
    scene = tmp_path / 'dup.yaml'
    scene.write_text('nodes: [valve_1]\nexchange_step_s: 1.0\nexchange_step_s: 2.0\n')
    line = one_line_error(*cli('params', scene)[::2])
    assert "duplicate key 'exchange_step_s'" in line and 'line 3' in line


def test_bag_repair_calls_a_damaged_chunk_damaged(demo_bag: pathlib.Path,
                                                  tmp_path: pathlib.Path) -> None:
    bag = _copy(demo_bag, tmp_path / 'bag')
    code, out, _ = cli('bag-repair', bag)
    assert code == 0 and 'valid' in out
    _damage_a_chunk(next(bag.glob('*.mcap')))
    code, out, _ = cli('bag-repair', bag)
    assert code == 0 and 'damaged' in out and '1 damaged chunk' in out, out
    code, out, _ = cli('bag-repair', bag)
    assert 'valid' in out                            # repaired once is whole
    assert cli('info', bag)[0] == 0


def test_resume_from_another_scene_is_refused(demo_bag: pathlib.Path,
                                              tmp_path: pathlib.Path) -> None:
    line = one_line_error(*cli('run', 'isometric_quick', '--resume', demo_bag, '--out',
                               tmp_path / 'r')[::2])
    assert "scene 'demo'" in line and 'isometric_quick' in line
    assert not (tmp_path / 'r').exists()


def test_ctrl_c_before_the_bag_exists_says_so(tmp_path: pathlib.Path,
                                              demo_bag: pathlib.Path) -> None:
    from pam_bench.cli.run import _interrupted
    assert 'nothing written' in _interrupted(tmp_path / 'none')
    assert 'bag closed in' in _interrupted(demo_bag)


@pytest.mark.parametrize('remaining, rate, text', [
    (100.0, 0.0, ''), (100.0, float('inf'), ''), (100.0, 50.0, '  ETA    2.0 s wall'),
    (-1.0, 10.0, '  ETA    0.0 s wall')])
def test_eta_is_a_number_or_absent(remaining: float, rate: float, text: str) -> None:
    from pam_bench.nodes.sim_clock import eta_text
    assert eta_text(remaining, rate) == text
