"""`make servo-compare` timed: every servo scene and controller through the composed nodes."""

from __future__ import annotations

import os
import pathlib
import time
from typing import Any

from benchmarks.study import Study
from benchmarks.tables import Row, commit_of, table
from pam_bench.bringup.servo_compare import compare_servo
from pam_bench.vocabulary.run import Layout

__all__ = ['STUDY']


def measure(quick: bool, out: pathlib.Path, scenes: list[str] | None) -> dict[str, Any]:
    """`make servo-compare`: every servo scene x controller through the composed nodes, one
    job per CPU; its wall time and rows (quick: servo_sin_t, 2 s runs)."""
    jobs = os.cpu_count() or 1
    t0 = time.perf_counter()
    rows = compare_servo(out / 'servo_compare', 'ros', ['servo_sin_t'] if quick else None,
                         2.0 if quick else None, layout=Layout.COMPOSED)
    return {'servo_compare': {'wall_s': time.perf_counter() - t0, 'jobs': jobs, 'runs': len(rows),
            'sim_s': sum(r['sim_s'] for r in rows), 'rows': rows}}


def section(r: dict[str, Any], root: pathlib.Path) -> list[str]:
    """Every run of `make servo-compare`."""
    sc = r['servo_compare']
    return [f"{sc['runs']} runs, {sc['sim_s']:.0f} s simulated, in {sc['wall_s']:.0f} s of wall "
            f"time with {sc['jobs']} jobs.", ''] + table(
        ['scene', 'controller', 'RMS error', 'max', 'sim s', 'wall s', 'real-time factor'],
        [(row['scene'], row['controller'], f"{row['rms_error']:.3f} {row['unit']}",
          f"{row['max_error']:.3f}", f"{row['sim_s']:.0f}", f"{row['wall_s']:.1f}",
          f"{row['real_time_factor']:.2f}x") for row in sc['rows']])


def results(r: dict[str, Any]) -> list[Row]:
    """The key result of the servo_compare study (`make servo-compare` timed)."""
    sc = r.get('servo_compare')
    if not sc:
        return []
    return [(f"`make servo-compare`: {sc['runs']} runs through the composed nodes",
             '< 6 min', f"{sc['wall_s'] / 60:.1f} min ({sc['sim_s']:.0f} s simulated, "
             f"{sc['jobs']} jobs)", commit_of(r, 'servo_compare'))]


STUDY = Study('servo_compare', '`make servo-compare`: every servo scene and controller through '
              'the composed nodes, timed', measure, (('servo_compare', section),), results)
"""`make servo-compare` timed (bench.json ``servo_compare``)."""
