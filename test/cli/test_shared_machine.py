"""Issue 51's cases as a user meets them on a shared machine: links, limits, signals, numbers
as YAML 1.2 writes them, plug-ins and bags nobody here wrote. Each ends in one line with the
exit code the README gives, and nothing that was there is lost."""

from __future__ import annotations

import os
import pathlib
import resource
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from test.cli.helpers import cli, one_line_error, tree_digest

# --- outputs resolve links first ---------------------------------------------------------


def test_overwrite_through_a_symlink_replaces_only_the_same_verbs_own(
        demo_bag: pathlib.Path, tmp_path: pathlib.Path) -> None:
    """A link to an extraction, given to run --overwrite: refused, nothing deleted; a link to
    a bag of a run: the bag it points to is replaced, the link stays a link."""
    report = tmp_path / 'report'
    assert cli('extract', demo_bag, '--out', report)[0] == 0
    link = tmp_path / 'link'
    link.symlink_to(report)
    before = tree_digest(report)
    line = one_line_error(*cli('run', 'demo', '--out', link, '--overwrite')[::2])
    assert 'holds the output of pam-bench extract, not of pam-bench run' in line, line
    assert tree_digest(report) == before
    bag = tmp_path / 'bag'
    assert cli('run', 'demo', '--out', bag)[0] == 0
    link.unlink()
    link.symlink_to(bag)
    code, out, err = cli('run', 'demo', '--out', link, '--overwrite', '--seed', '3')
    assert code == 0, out + err
    assert link.is_symlink() and (bag / 'metadata.yaml').exists()
    assert 'seed: 3' in (bag / 'metadata.yaml').read_text()


@pytest.mark.parametrize('verb', [('run', 'demo'), ('extract', 'BAG'),
                                  ('sweep', 'identification')])
def test_an_empty_out_is_one_line(verb: tuple[str, str], demo_bag: pathlib.Path,
                                  tmp_path: pathlib.Path) -> None:
    os.chdir(tmp_path)
    args = [demo_bag if a == 'BAG' else a for a in verb]
    code, _, err = cli(*args, '--out', '')
    assert code == 2 and 'an empty path' in err and 'Traceback' not in err, err
    assert not list(tmp_path.iterdir())


def test_a_name_longer_than_the_file_system_takes_is_one_line(tmp_path: pathlib.Path) -> None:
    line = one_line_error(*cli('run', 'demo', '--out', tmp_path / ('x' * 300))[::2])
    assert 'over the 255 the file system takes' in line, line


# --- limits --------------------------------------------------------------------------------

def _limited(limit: int, soft: int, *args: str, cwd: pathlib.Path) -> subprocess.CompletedProcess:
    def apply() -> None:
        resource.setrlimit(limit, (soft, soft))
    return subprocess.run([sys.executable, '-m', 'pam_bench.cli', *args], cwd=cwd,
                          preexec_fn=apply, capture_output=True, text=True, timeout=120)


def test_a_file_size_limit_is_one_line_and_the_bag_repairable(tmp_path: pathlib.Path,
                                                              ros_domain: int) -> None:
    """ulimit -f: the recorder's write fails with EFBIG; one line, exit 1, and bag-repair
    makes a valid bag of what reached the disk."""
    res = _limited(resource.RLIMIT_FSIZE, 400_000, 'run', 'campaign_quick', '--out', 'bag',
                   cwd=tmp_path)
    assert res.returncode != 0, res.stdout + res.stderr
    assert 'Traceback' not in res.stderr, res.stderr
    assert 'file-size limit' in res.stdout + res.stderr, res.stdout + res.stderr
    code, out, err = cli('bag-repair', tmp_path / 'bag')
    assert code == 0 or 'valid' in out, out + err
    assert cli('info', tmp_path / 'bag')[0] == 0


def test_too_few_file_descriptors_is_one_line(tmp_path: pathlib.Path, ros_domain: int) -> None:
    for verb in (('run', 'demo', '--out', 'bag'), ('sweep', 'identification', '--out', 'sw')):
        res = _limited(resource.RLIMIT_NOFILE, 12, *verb, cwd=tmp_path)
        assert res.returncode == 2, res.stderr
        assert res.stderr.strip() == ('error: the open-file limit is 12 (ulimit -n); pam-bench '
                                      'needs at least 64: raise it (ulimit -n 1024)')
        assert not list(tmp_path.iterdir())


STUCK = textwrap.dedent("""
    import importlib, signal
    main = importlib.import_module('pam_bench.cli.main')
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGTERM, signal.SIGINT})
    signal.signal(signal.SIGTERM, main._raise_interrupt)
    main._watch_stops()
    # the main thread in a C call that never returns to Python (a read nobody answers, the
    # stop signals blocked here): a stop signal goes to another thread, Python's handler
    # never runs
    import os
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM, signal.SIGINT})
    silent, _ = os.pipe()
    print('stuck', flush=True)
    os.read(silent, 1)
""")


def test_a_process_stuck_in_c_still_ends_on_a_second_sigterm() -> None:
    """What a library spinning on a refused allocation does to a run (``ulimit -v``): the
    main thread never returns to Python; the stop watch ends the process anyway."""
    proc = subprocess.Popen([sys.executable, '-c', STUCK], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None and proc.stdout.readline().strip() == 'stuck'
        time.sleep(0.5)                  # in the read by now (before it, Python would act)
        proc.send_signal(signal.SIGTERM)
        time.sleep(0.5)                  # two signals sent at once may arrive as one
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=20)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 143, err
    assert 'a second stop signal: exited at once' in err and 'Traceback' not in err


# --- numbers and settings --------------------------------------------------------------------

@pytest.mark.parametrize('text, value', [('1e4', 1e4), ('2e-3', 2e-3), ('1.0e5', 1e5),
                                         ('+1E2', 100.0)])
def test_exponents_without_a_sign_or_a_dot_are_floats(text: str, value: float) -> None:
    from pam_bench.vocabulary.yaml_io import load_yaml
    assert load_yaml(f'x: {text}', 'test') == {'x': value}


def test_set_takes_an_exponent(tmp_path: pathlib.Path, ros_domain: int) -> None:
    code, out, err = cli('run', 'demo', '--out', tmp_path / 'bag', '--set',
                         'sequencer.stale_timeout_s=2e0')
    assert code == 0, out + err


@pytest.mark.parametrize('flag, value, words', [
    ('--max-bag-duration', '0.001s', 'below its minimum 1.0 s (or 0: off)'),
    ('--max-bag-size', '10k', 'below its minimum 100000 B (or 0: off)')])
def test_bag_limits_are_range_checked(tmp_path: pathlib.Path, flag: str, value: str,
                                      words: str) -> None:
    code, _, err = cli('run', 'demo', '--out', tmp_path / 'bag', flag, value)
    assert code == 2 and words in err and not (tmp_path / 'bag').exists(), err


@pytest.mark.parametrize('nodes, words', [
    ('[]', 'nodes is empty'), ('[valve_1, valve_1, sequencer]', "node 'valve_1' is named 2 "
                               'times'), ('[valve_1, muscle_1]', 'nothing ends the run')])
def test_a_scene_that_cannot_run_is_one_line(tmp_path: pathlib.Path, nodes: str,
                                             words: str) -> None:
    scene = tmp_path / 'bad.yaml'
    scene.write_text(f'nodes: {nodes}\nprotocol: demo\nexchange_step_s: 0.01\n')
    line = one_line_error(*cli('run', scene, '--out', tmp_path / 'bag')[::2])
    assert words in line, line


# --- bags nobody here wrote ------------------------------------------------------------------

def _foreign_bag(path: pathlib.Path, topic: str) -> None:
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore
    store = get_typestore(Stores.ROS2_JAZZY)
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conn = w.add_connection(topic, 'std_msgs/msg/String', typestore=store)
        msg = store.types['std_msgs/msg/String'](data='hello')
        w.write(conn, 1, store.serialize_cdr(msg, 'std_msgs/msg/String'))


@pytest.mark.parametrize('topic, words', [
    ('/chatter', 'not a pam_bench bag: it has no /protocol/point or /protocol/step_response '
                 '(it holds /chatter)'),
    ('/protocol/point', 'not a pam_bench bag: /protocol/point holds std_msgs/msg/String, not '
                        'pam_bench_interfaces/msg/CharacteristicPoint')])
def test_a_valid_bag_of_another_recorder_is_named_not_damaged(tmp_path: pathlib.Path,
                                                             topic: str, words: str) -> None:
    bag = tmp_path / 'foreign'
    _foreign_bag(bag, topic)
    code, out, _ = cli('info', bag)
    assert code == 0 and 'std_msgs/msg/String' in out           # read for what it holds
    line = one_line_error(*cli('extract', bag, '--out', tmp_path / 'report')[::2])
    assert words in line and 'damaged' not in line, line
    assert cli('bag-repair', bag)[0] == 0                        # valid: nothing to repair
