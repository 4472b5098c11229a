"""One scene run as the studies time it: in this process (wall time with start-up, lock-step
rate, deliveries), or as a lab runs a command (``command_run``)."""

from __future__ import annotations

import os
import pathlib
import subprocess
import sys
import time
from collections.abc import Sequence
from typing import Any

from pam_bench.bringup.runner import run_scene
from pam_bench.config.scene import load_scene
from pam_bench.vocabulary.run import Layout, RunOptions

__all__ = ['scene_run', 'scene_bag', 'command_run']


def scene_bag(name: str, out: pathlib.Path, layout: Layout) -> pathlib.Path:
    """Where ``scene_run`` records scene ``name`` in ``out`` (one folder per layout)."""
    return out / f'{name}{"_one" if layout is Layout.COMPOSED else ""}'


def scene_run(name: str, out: pathlib.Path, layout: Layout = Layout.PROCESSES
              ) -> dict[str, Any]:
    """Run scene ``name`` into ``out`` (``scene_bag``) in ``layout``; its timing row."""
    t0 = time.perf_counter()
    bag = scene_bag(name, out, layout)
    res = run_scene(load_scene(name), str(bag), RunOptions(layout=layout, quiet=True))
    wall = time.perf_counter() - t0
    row = {'scene': name, 'layout': layout.value,
           'code': res.code, 'exchange_steps': res.steps, 'sim_s': res.sim_s,
           'wall_s_lockstep': res.wall_s, 'wall_s_total': wall,
           'real_time_factor': res.sim_s / res.wall_s if res.wall_s else 0.0,
           'lockstep_rate_steps_per_s': res.rate}
    if 'deliveries' in res.stats and res.steps:
        # the messages to subscriptions per exchange: the same nodes and topics in separate
        # processes, where each is a DDS delivery (clock ticks and acknowledgements included)
        row['deliveries_per_exchange'] = res.stats['deliveries'] / res.steps
    return row


def command_run(args: Sequence[str], path: Sequence[pathlib.Path], label: str,
                cwd: pathlib.Path | None = None, timeout_s: float = 900.0) -> float:
    """``python -m pam_bench.cli ARGS`` in a child process, as a lab runs a command: its wall
    time, s, start-up and end included. ``path`` goes first on its ``PYTHONPATH`` (the sources
    it runs); it stays on loopback in the study's ``ROS_DOMAIN_ID``, and writes and uses its
    bytecode (``PYTHONDONTWRITEBYTECODE`` is not passed on: a fresh tree would compile every
    module on every run).

    Raises:
        RuntimeError: the command failed (``label``, its exit status, its last output).
    """
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(str(p) for p in path),
               ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    env.pop('PYTHONDONTWRITEBYTECODE', None)
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, '-m', 'pam_bench.cli', *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=timeout_s)
    took = time.perf_counter() - t0
    if done.returncode != 0:
        raise RuntimeError(f'{label}: exit {done.returncode}: '
                           f'{(done.stdout + done.stderr)[-300:]}')
    return took
