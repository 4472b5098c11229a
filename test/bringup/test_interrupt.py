"""Ctrl-C or SIGTERM during a run: nodes stop, no orphan, the bag is closed and valid."""

from __future__ import annotations

import os
import pathlib
import signal
import subprocess
import sys
import time

import pytest

from pam_bench.bags.baginfo import bag_info
from test.helpers import bag_payloads


def node_processes(run: subprocess.Popen) -> list[int]:
    """PIDs of the pam_bench node processes the run ``run`` started (``PAM_BENCH_RUN`` in
    their environment: found whatever ROS domain the run leased)."""
    pids = []
    for d in pathlib.Path('/proc').iterdir():
        if not d.name.isdigit():
            continue
        try:
            cmd = (d / 'cmdline').read_bytes()
            env = (d / 'environ').read_bytes()
        except OSError:
            continue
        if b'pam_bench.nodes' in cmd and f'PAM_BENCH_RUN={run.pid}\0'.encode() in env:
            pids.append(int(d.name))
    return pids


def start_run(scene: str, bag: pathlib.Path, ignore_sigint: bool = False,
              extra: tuple[str, ...] = (), progress_lines: int = 1
              ) -> tuple[subprocess.Popen, list[str]]:
    """``pam-bench run SCENE`` in a child process, returned once it has printed
    ``progress_lines`` progress lines (the first comes with the first step, the next one
    progress period later, so 2 means it has been stepping for a while even on a busy machine)."""
    proc = subprocess.Popen([sys.executable, '-m', 'pam_bench.cli', 'run', scene,
                             '--out', str(bag), *extra], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True,
                            preexec_fn=_ignore_sigint if ignore_sigint else None)
    lines = []
    seen = 0
    for line in proc.stdout:
        lines.append(line)
        seen += line.startswith('[sim')
        if seen >= progress_lines:
            break
    return proc, lines


def _ignore_sigint() -> None:
    """What a background job of a non-interactive shell (``cmd &``) inherits."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


@pytest.mark.parametrize('sig, inherited, layout', [
    (signal.SIGINT, 'default', ('--processes',)), (signal.SIGTERM, 'default', ('--processes',)),
    (signal.SIGINT, 'ignored', ('--processes',)), (signal.SIGINT, 'ignored', ()),
    (signal.SIGTERM, 'default', ())])
def test_interrupted_run_leaves_a_valid_bag(tmp_path: pathlib.Path, ros_domain: int,
                                            sig: signal.Signals, inherited: str,
                                            layout: tuple[str, ...]) -> None:
    bag = tmp_path / 'bag'
    # the full campaign: minutes of wall time in either layout, so the signal comes mid-run
    proc, lines = start_run('campaign', bag, ignore_sigint=inherited == 'ignored',
                            extra=layout, progress_lines=2)
    try:
        assert proc.poll() is None, ''.join(lines)
        time.sleep(0.2)
        proc.send_signal(sig)
        out, _ = proc.communicate(timeout=60)
        out = ''.join(lines) + out
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == (143 if sig == signal.SIGTERM else 130), out
    assert f'interrupted: nodes stopped, bag closed in {bag}' in out, out
    assert bag_info(str(bag))['end']['state'] == 'interrupted'
    payloads = bag_payloads(bag)
    assert len(payloads['/load_cell_1/force']) > 5       # what ran before the signal
    time.sleep(0.5)
    assert node_processes(proc) == []


def test_dead_node_ends_the_run_with_a_reason(tmp_path: pathlib.Path, ros_domain: int) -> None:
    bag = tmp_path / 'bag'
    # a stall is found after stall_timeout_s (10 s by default): 4 s is still far above any
    # acknowledgment a loaded machine delays
    proc, lines = start_run('isotonic', bag,
                            extra=('--processes', '--set', 'sim_clock.stall_timeout_s=4'))
    try:
        muscle = [p for p in node_processes(proc)
                  if b'muscle_sim' in pathlib.Path(f'/proc/{p}/cmdline').read_bytes()]
        assert len(muscle) == 1, ''.join(lines)
        os.kill(muscle[0], signal.SIGKILL)
        out, _ = proc.communicate(timeout=90)
        out = ''.join(lines) + out
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode not in (0, 130), out
    assert 'muscle_1' in out and 'stalled' in out
    from test.helpers import bag_messages
    statuses = bag_messages(bag, '/protocol/status')
    assert statuses[-1].state == 3 and 'muscle_1' in statuses[-1].reason      # ABORTED
    time.sleep(0.5)
    assert node_processes(proc) == []


def test_a_killed_lockstep_run_loses_about_a_second(tmp_path: pathlib.Path,
                                                    ros_domain: int) -> None:
    """SIGKILL of every process leaves no metadata; the chunks the recorder closes once a wall
    second are on disk, and bag-repair makes a valid bag of them (the README: a killed run
    loses at most its last second). The separate processes of a sparse protocol write less
    than a chunk's megabyte in seconds: before, nothing reached the disk."""
    from pam_bench.bags.bag_repair import repair_bag
    bag = tmp_path / 'bag'
    proc, lines = start_run('isometric', bag, extra=('--processes',), progress_lines=1)
    try:
        assert proc.poll() is None, ''.join(lines)
        end = time.monotonic() + 30.0    # past the first flushes (a wall second each): on a
        while time.monotonic() < end:    # loaded machine the run is slower, so wait for data
            part = list(bag.glob('.part_*/*.mcap'))
            if part and part[0].stat().st_size > 60_000:
                break
            time.sleep(0.1)
        for pid in [proc.pid, *node_processes(proc)]:
            os.kill(pid, signal.SIGKILL)
        proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
        for pid in node_processes(proc):
            os.kill(pid, signal.SIGKILL)
    from pam_bench.bags.splitwriter import bag_in_use
    end = time.monotonic() + 20.0        # gone, its lock on the bag with it (a killed
    while (node_processes(proc) or bag_in_use(bag)) and time.monotonic() < end:
        time.sleep(0.05)                 # process on a loaded machine takes a while)
    part = list(bag.glob('.part_*/*.mcap'))
    assert part and part[0].stat().st_size > 0, 'nothing on disk after seconds of a run'
    report = repair_bag(bag)
    assert report.needed and report.kept.get('/load_cell_1/force', 0) > 100, report
    assert bag_info(str(bag))['topics']['/load_cell_1/force']['count'] > 100
