"""A lock-step run with every node in its own process (``--processes``; two hosts with
``netns``).

A node that stops at start-up (a bad parameter) ends the run at once with that node's one-line
error; the clock's ``RunSummary`` comes back as JSON (``summary_file``), not as text to parse.
Node processes run under SCHED_BATCH unless paced (``common.batch_child``).
"""

from __future__ import annotations

import dataclasses
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from typing import Any

from pam_bench.bringup.common import (
    RunResult,
    batch_child,
    die_with_parent,
    node_cmd,
    node_error,
    result_of,
    ros_env,
    stop_processes,
    write_end_state,
    write_params_file,
)
from pam_bench.config.nodes import devices
from pam_bench.config.scene import Scene
from pam_bench.sim.lockstep import RunSummary

__all__ = ['run_processes']


def _watch(procs: dict[str, subprocess.Popen], clock: subprocess.Popen,
           failed: list[str]) -> None:
    """Stop the clock when a node could not start (exit code 2: a bad parameter, its one
    line in the log); a node that dies later stalls the lock-step, and the clock says so."""
    while clock.poll() is None:
        for name, p in procs.items():
            if p.poll() is not None and p.returncode == 2:
                failed.append(name)
                if clock.poll() is None:
                    clock.send_signal(signal.SIGTERM)
                return
        time.sleep(0.05)


def _in_netns(name: str, netns: tuple[str, str] | None, cmd: list[str]) -> list[str]:
    """``cmd`` run in the device namespace (simulated devices) or the other one."""
    if netns is None:
        return cmd
    return ['ip', 'netns', 'exec', netns[0] if devices([name]) else netns[1], *cmd]


def run_processes(scene: Scene, settings: dict[str, Any], domain_id: int | None,
                   quiet: bool, netns: tuple[str, str] | None = None) -> RunResult:
    """Run the scene, one process per node (module docstring)."""
    env = ros_env(domain_id, 'SUBNET' if netns else 'LOCALHOST')
    procs: dict[str, subprocess.Popen] = {}
    failed: list[str] = []
    with tempfile.TemporaryDirectory(prefix='pam_bench_') as tmp:
        pfile = os.path.join(tmp, 'params.yaml')
        summary_file = os.path.join(tmp, 'summary.json')
        settings['sim_clock'] = dataclasses.replace(settings['sim_clock'],
                                                    summary_file=summary_file)
        write_params_file(settings, pfile)
        log = open(os.path.join(tmp, 'nodes.log'), 'w+', encoding='utf-8')
        paced = settings['sim_clock'].realtime
        child = die_with_parent if paced else batch_child     # paced: wake-ups matter
        try:
            order = [n for n in scene.nodes if n != 'recorder']
            if 'recorder' in scene.nodes:
                order.insert(0, 'recorder')
            for name in order:
                procs[name] = subprocess.Popen(_in_netns(name, netns, node_cmd(name, pfile)),
                                               env=env, stdout=log, stderr=subprocess.STDOUT,
                                               preexec_fn=child)
            clock = subprocess.Popen(_in_netns('sim_clock', netns,
                                               node_cmd('sim_clock', pfile)),
                env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                preexec_fn=child)
            watcher = threading.Thread(target=_watch, args=(dict(procs), clock, failed),
                                       daemon=True)
            watcher.start()
            procs = {'sim_clock': clock, **procs}
            lines = []
            assert clock.stdout is not None
            for line in clock.stdout:
                if not quiet and (line.startswith('[sim') or line.startswith('lock-step:')):
                    print(line, end='', flush=True)     # shown once: not again below
                else:
                    lines.append(line)
            code = clock.wait()
            dead = [n for n, p in procs.items() if n != 'sim_clock' and p.poll() is not None]
        finally:
            write_end_state(settings, code if 'code' in locals() else None)
            stop_processes(procs)
            log.flush()
            log.seek(0)
            node_log = log.read()
            log.close()
        summary = None
        if os.path.exists(summary_file):
            with open(summary_file, encoding='utf-8') as fh:
                summary = RunSummary.from_json(fh.read())
        result = result_of(summary, code)
        if failed:
            result.code = 2
            result.summary = node_error(node_log) or f'node {failed[0]} stopped'
            sys.stderr.write(f'error: {result.summary}\n')
        elif code != 0 or dead:
            result.code = code or 5
            sys.stderr.write(''.join(lines)[-3000:] + node_log[-4000:])
    return result
