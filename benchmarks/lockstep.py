"""Study ``lockstep``: one lock-step exchange of the demo against the rclpy ping-pong."""

from __future__ import annotations

import pathlib
from typing import Any

from benchmarks.runs import scene_run
from benchmarks.study import Study
from benchmarks.tables import Row, commit_of, table
from pam_bench.bringup.pingpong import pingpong_rate

__all__ = ['STUDY']


def measure(quick: bool, out: pathlib.Path, scenes: list[str] | None) -> dict[str, Any]:
    """The ping-pong rate and the demo's lock-step rate in separate processes."""
    pp = pingpong_rate(3000)
    demo = scene_run('demo', out)
    return {'lockstep': {'pingpong_round_trips_per_s': pp,
                         'demo_lockstep_steps_per_s': demo['lockstep_rate_steps_per_s'],
                         'ratio_lockstep_to_pingpong': demo['lockstep_rate_steps_per_s'] / pp,
                         'participants': 7, 'demo': demo}}


def section(r: dict[str, Any], root: pathlib.Path) -> list[str]:
    """The two rates and their ratio."""
    ls = r['lockstep']
    return table(['measure', 'rate'], [
        ('rclpy ping-pong, two processes', f"{ls['pingpong_round_trips_per_s']:.0f} round "
         'trips/s'),
        (f"lock-step, demo scene (10 ms exchanges), {ls['participants']} participants in "
         'separate processes', f"{ls['demo_lockstep_steps_per_s']:.0f} exchanges/s"),
        ('ratio lock-step / ping-pong', f"{ls['ratio_lockstep_to_pingpong']:.3f}")])


def results(r: dict[str, Any]) -> list[Row]:
    """One exchange in round trips."""
    ls = r.get('lockstep')
    if not ls:
        return []
    return [('one lock-step exchange (demo, 7 participants)', 'a few round trips',
             f"{1 / ls['ratio_lockstep_to_pingpong']:.1f} round trips "
             f"({ls['demo_lockstep_steps_per_s']:.0f} exchanges/s against "
             f"{ls['pingpong_round_trips_per_s']:.0f} round trips/s)",
             commit_of(r, 'lockstep'))]


STUDY = Study('lockstep', 'the demo lock-step rate against the rclpy ping-pong', measure,
              (('lockstep', section),), results, quick=False)
"""The lock-step against the ping-pong (bench.json ``lockstep``); a quick run leaves it out: the
layouts study measures the same ping-pong and the demo in separate processes beside it."""
