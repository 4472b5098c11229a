"""Study ``side_by_side``: the composed nodes now against commit ``BASE``, run for run (issue 54,
'Twice as fast through the composed nodes').

A worktree of ``BASE`` (``git worktree add --detach``) beside this checkout; both run from the
same venv, each with its own sources first on the path. Each scene of ``SCENES`` runs as a lab
runs it, ``python -m pam_bench.cli run SCENE`` (start-up and end included), alternated
``BASE`` then this checkout, after one warm-up run of each (numba's cache filled for each
tree's sources, and each tree's bytecode written: ``PYTHONDONTWRITEBYTECODE`` is not passed
on, so neither tree compiles its sources on every run as a fresh worktree would). The wall
time of each command, its median per scene and tree, the speed-up (``BASE``'s median over this
checkout's) against the issue's goal, and whether the last two bags hold the same readings
(``pam-bench diff``: ``READINGS``). The worktree is removed at the end.
"""

from __future__ import annotations

import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
from typing import Any

from benchmarks.errors import UsageError
from benchmarks.runs import command_run
from benchmarks.study import Study
from benchmarks.tables import Row, commit_of, spread, table

__all__ = ['STUDY', 'BASE', 'SCENES', 'measure', 'section', 'results']

BASE = '7e50f37'
"""The commit the issue measures against."""
SCENES = {'demo': (7, 1.5), 'campaign_quick': (7, 1.5), 'servo_sin_t': (5, 1.7),
          'campaign': (3, 2.0)}
"""Scene -> (alternated runs, the speed-up the issue asks)."""
QUICK = ('demo', 'campaign_quick')
ROOT = pathlib.Path(__file__).resolve().parents[1]


def _run(tree: pathlib.Path, scene: str, out: pathlib.Path) -> float:
    """One ``pam-bench run`` of ``tree``'s sources (s of wall time; ``runs.command_run``)."""
    return command_run(['run', scene, '--out', str(out), '--overwrite'], (tree,),
                       f'{scene} ({tree.name})', cwd=tree)


READINGS = {0: 'identical', 1: 'differ', 2: 'none to compare'}
"""``pam-bench diff``'s exit status -> what the table says (2: a bag without readings, as a
servo scene's)."""


def _readings(a: pathlib.Path, b: pathlib.Path) -> str:
    """Whether two bags hold the same readings (``READINGS`` of ``pam-bench diff``)."""
    done = subprocess.run([sys.executable, '-m', 'pam_bench.cli', 'diff', str(a), str(b)],
                          cwd=ROOT, capture_output=True, text=True, timeout=300,
                          env=dict(os.environ, PYTHONPATH=str(ROOT)))
    return READINGS.get(done.returncode, f'diff failed ({done.returncode})')


def measure(quick: bool) -> dict[str, Any]:
    """Every scene, ``BASE`` against this checkout (module docstring); quick: demo and
    campaign_quick, two runs each.

    Raises:
        UsageError: ``BASE`` is not in this checkout's history (a shallow clone).
    """
    out: dict[str, Any] = {'base': BASE, 'scenes': {}}
    with tempfile.TemporaryDirectory(prefix='pam_bench_side_') as tmp:
        base = pathlib.Path(tmp) / BASE
        added = subprocess.run(['git', '-C', str(ROOT), 'worktree', 'add', '--detach',
                                str(base), BASE], capture_output=True, text=True, timeout=120)
        if added.returncode != 0:
            raise UsageError(f'no worktree of {BASE}: {added.stderr.strip()[-200:]}')
        try:
            for scene, (runs, goal) in SCENES.items():
                if quick and scene not in QUICK:
                    continue
                runs = 2 if quick else runs
                times: dict[str, list[float]] = {'base': [], 'now': []}
                bags = {k: pathlib.Path(tmp) / f'{scene}_{k}' for k in times}
                for i in range(runs + 1):
                    for kind, tree in (('base', base), ('now', ROOT)):
                        took = _run(tree, scene, bags[kind])
                        if i:                                 # the first: the warm-up
                            times[kind].append(took)
                out['scenes'][scene] = {'times': times, 'goal': goal,
                                        'readings': _readings(*bags.values())}
        finally:
            subprocess.run(['git', '-C', str(ROOT), 'worktree', 'remove', '--force',
                            str(base)], capture_output=True, timeout=120)
    return out


def _speed_up(s: dict[str, Any]) -> float:
    """``BASE``'s median over this checkout's."""
    return statistics.median(s['times']['base']) / statistics.median(s['times']['now'])


def section(r: dict[str, Any]) -> list[str]:
    """One row per scene: both trees' times, the speed-up, the goal, the readings."""
    c = r['side_by_side']
    rows: list[Row] = []
    for scene, s in c['scenes'].items():
        rows.append((scene, len(s['times']['now']), spread(s['times']['base']),
                     spread(s['times']['now']), f'{_speed_up(s):.2f}x',
                     f"{s['goal']}x", s['readings']))
    return table(['scene', 'runs', f"`{c['base']}`", 'now', 'speed-up (medians)', 'goal',
                  'readings of the last two bags'], rows)


def results(r: dict[str, Any]) -> list[Row]:
    """The speed-up per scene against the issue's goals."""
    c = r.get('side_by_side')
    if not c:
        return []
    goals = ', '.join(f"{s} {v['goal']}x" for s, v in c['scenes'].items())
    got = ', '.join(f'{s} {_speed_up(v):.2f}x' for s, v in c['scenes'].items())
    return [(f"`pam-bench run` through the composed nodes against `{c['base']}`, start-up "
             'included (speed-up of the medians)', goals, got, commit_of(r, 'side_by_side'))]


STUDY = Study(
    'side_by_side', f'the composed nodes against {BASE}: demo, campaign_quick, servo_sin_t and '
    'the campaign, run for run',
    lambda quick, out, scenes: {'side_by_side': measure(quick)},
    (('side_by_side', lambda r, root: section(r)),), results, quick=False)
"""This checkout against the issue's commit (bench.json ``side_by_side``)."""
