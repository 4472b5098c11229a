"""Where the wall time of one exchange goes: a scene profiled through the nodes, in separate
processes and composed in one, the time of every process split by cause.

Every node process (or the one composed process) runs under cProfile
(``runtime.profiling``); each function's own time is put under one cause by the file and name
it belongs to: the physics (models, numpy, scipy), the nodes' glue (message <-> model), the
lock-step bookkeeping (input windows, acknowledgements, the clock, the intra-process bus),
message objects (building and reading rosidl messages), serialisation, DDS and the executor
(rclpy's take, publish and wait sets), waiting (a process blocked with nothing to do) and the
bag (rosbags' MCAP writer). Divided by the exchanges of the run: microseconds per exchange.
"""

from __future__ import annotations

import dataclasses
import os
import pathlib
import pstats
import tempfile
from typing import Any

from benchmarks.study import Study
from benchmarks.tables import commit_of, table
from pam_bench.bringup.runner import run_scene
from pam_bench.config.scene import load_scene
from pam_bench.runtime.profiling import ENV
from pam_bench.vocabulary.run import Layout, RunOptions

__all__ = ['STUDY', 'CAUSES', 'cause_of', 'profile_scene']

CAUSES = ('physics', 'node glue', 'lock-step bookkeeping', 'message objects', 'serialisation',
          'DDS and executor', 'waiting', 'bag writing', 'other')


def cause_of(filename: str, function: str) -> str:
    """The cause a function's own time is counted under (module docstring). ``runtime`` holds
    what ``nodes`` held when the first rows were measured (``01807b6``): its files count as
    they did there (``base`` and ``intra`` as bookkeeping, the rest as glue), so that the rows
    compare."""
    f = filename.replace('\\', '/')
    if f == '~':                                  # a builtin: its name says whose it is
        if 'serializ' in function:
            return 'serialisation'
        if 'wait' in function and ('WaitSet' in function or 'rclpy' in function):
            return 'waiting'
        if 'rclpy' in function:
            return 'DDS and executor'
        if 'numpy' in function or 'scipy' in function or 'ndarray' in function:
            return 'physics'
        return 'other'
    if 'rclpy/serialization' in f:
        return 'serialisation'
    if 'rosbags' in f or '/mcap' in f:
        return 'bag writing'
    if '/msg/_' in f or '/action/_' in f or '/srv/_' in f or 'importlib' in f:
        return 'message objects'
    if 'rclpy' in f:
        return 'DDS and executor'
    if any(k in f for k in ('pam_bench/sim/', 'pam_bench/runtime/base',
                            'pam_bench/runtime/intra', 'pam_bench/nodes/sim_clock',
                            'pam_bench/nodes/recorder')):
        return 'lock-step bookkeeping'
    if any(k in f for k in ('pam_bench/models', 'pam_bench/control', 'pam_bench/protocol',
                            '/numpy/', '/scipy/')):
        return 'physics'
    if 'pam_bench/nodes' in f or 'pam_bench/runtime' in f:
        return 'node glue'
    return 'other'


def _split(prof_dir: pathlib.Path) -> dict[str, dict[str, float]]:
    """Process name -> cause -> seconds (own time)."""
    out: dict[str, dict[str, float]] = {}
    for path in sorted(prof_dir.glob('*.prof')):
        st = pstats.Stats(str(path))
        by = dict.fromkeys(CAUSES, 0.0)
        for (filename, _, function), row in st.stats.items():   # type: ignore[attr-defined]
            by[cause_of(filename, function)] += row[2]
        out[path.stem] = by
    return out


def profile_scene(name: str, duration_s: float, layout: Layout) -> dict[str, Any]:
    """Run ``name`` cut to ``duration_s`` of sim time with every process profiled.

    Returns:
        {'scene', 'layout', 'exchanges', 'wall_s', 'wall_us_per_exchange', 'us_per_exchange':
        cause -> microseconds per exchange summed over the processes, 'processes': process ->
        cause -> microseconds per exchange}.
    """
    scene = dataclasses.replace(load_scene(name), duration_s=duration_s)
    for var in ('OPENBLAS_NUM_THREADS', 'OMP_NUM_THREADS', 'MKL_NUM_THREADS'):
        os.environ.setdefault(var, '1')      # as the CLI: BLAS pools only spin on 2 cores
    with tempfile.TemporaryDirectory(prefix='pam_bench_prof_') as tmp:
        prof = pathlib.Path(tmp) / 'prof'
        old = os.environ.get(ENV)
        os.environ[ENV] = str(prof)
        try:
            res = run_scene(scene, str(pathlib.Path(tmp) / 'bag'),
                            RunOptions(layout=layout, quiet=True))
        finally:
            if old is None:
                os.environ.pop(ENV, None)
            else:
                os.environ[ENV] = old
        split = _split(prof)
    n = max(res.steps, 1)
    per = {p: {c: 1e6 * s / n for c, s in by.items()} for p, by in split.items()}
    total = {c: sum(p[c] for p in per.values()) for c in CAUSES}
    return {'scene': name, 'layout': layout.value,
            'exchanges': res.steps, 'wall_s': res.wall_s,
            'wall_us_per_exchange': 1e6 * res.wall_s / n, 'us_per_exchange': total,
            'processes': per}


def measure(quick: bool, out: pathlib.Path, scenes: list[str] | None) -> dict[str, Any]:
    """servo_sin_t (2 s) in both layouts and campaign_quick composed, profiled (quick: the
    composed servo only; the separate-process one runs at about a fifth of real time)."""
    runs = [('servo_sin_t', 2.0, Layout.COMPOSED)]
    if not quick:
        runs += [('servo_sin_t', 2.0, Layout.PROCESSES), ('campaign_quick', 0.0, Layout.COMPOSED)]
    return {'profile': [profile_scene(name, dur, layout) for name, dur, layout in runs]}


def section(r: dict[str, Any], root: pathlib.Path) -> list[str]:
    """Microseconds per exchange by cause, per profiled run; with ``profile_before`` in the
    results (the rows of an earlier measurement and its commit), those rows first, each scene
    and layout's earlier row above its row now (issue 54 item 3)."""
    def key(p: dict[str, Any]) -> tuple[str, str]:
        return p['scene'], Layout.parse(p['layout']).value     # an older name, as now

    before = r.get('profile_before') or {'commit': '', 'rows': []}
    earlier = {key(p): p for p in before['rows']}
    rows: list[tuple[str, dict[str, Any]]] = []
    for p in r['profile']:
        if key(p) in earlier:
            rows.append((f"`{before['commit']}`", earlier[key(p)]))
        rows.append((commit_of(r, 'profile'), p))
    head = ['commit', 'scene', 'layout', 'wall us / exchange (profiled)'] + list(CAUSES)
    return table(head, [(commit, *key(p), f"{p['wall_us_per_exchange']:.0f}")
                        + tuple(f"{p['us_per_exchange'][c]:.0f}" for c in CAUSES)
                        for commit, p in rows])


STUDY = Study('profile', 'where the wall time of an exchange goes, by cause', measure,
              (('profile', section),))
"""Where an exchange's time goes (bench.json ``profile``)."""
