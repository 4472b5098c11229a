"""One scene run as the studies time it: wall time with start-up, lock-step rate, deliveries."""

from __future__ import annotations

import pathlib
import time
from typing import Any

from pam_bench.bringup.runner import run_scene
from pam_bench.config.scene import load_scene
from pam_bench.vocabulary.run import Layout, RunOptions

__all__ = ['scene_run', 'scene_bag']


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
