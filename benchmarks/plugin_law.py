"""Study ``plugin_law``: a lab's force law against the built-in muscle, run for run (issue 55,
'Plug-in laws compiled like the built-ins').

The example package (``examples/pam_bench_example``, its law ``hunt_graber_quinn``) is
installed with pip into a scratch folder put on the commands' path, the venv left as it is.
Each scene of ``SCENES`` is run as a lab runs it, ``pam-bench run SCENE``, once with the
bench's McKibben muscle and once with ``--set muscle_1.muscle.kind=law --set
muscle_1.muscle.law=hunt_graber_quinn``, alternated ``RUNS`` times after one warm-up run of
each (numba's cache filled); the wall time of each command, its median per scene and muscle,
and their ratio. The scene decides how the law runs (``muscle.law_core: auto``,
``models.law_muscle.law_core_for``): the demo's 10 ms exchanges run it as written,
campaign_quick's 3 s exchanges compiled.
"""

from __future__ import annotations

import pathlib
import statistics
import subprocess
import sys
import tempfile
from typing import Any

from benchmarks.runs import command_run
from benchmarks.study import Study
from benchmarks.tables import Row, commit_of, spread, table

__all__ = ['STUDY', 'SCENES', 'RUNS', 'LAW', 'measure', 'section', 'results']

SCENES = ('demo', 'campaign_quick')
RUNS = 5
LAW = 'hunt_graber_quinn'
GOAL = 1.5
ROOT = pathlib.Path(__file__).resolve().parents[1]


def _run(site: pathlib.Path, scene: str, law: bool, out: pathlib.Path) -> float:
    """One ``pam-bench run`` (s of wall time; ``runs.command_run``)."""
    args = ['run', scene, '--out', str(out)]
    if law:
        args += ['--set', 'muscle_1.muscle.kind=law', '--set', f'muscle_1.muscle.law={LAW}']
    return command_run(args, (site, ROOT), scene, timeout_s=600.0)


def measure(quick: bool) -> dict[str, Any]:
    """Every scene with both muscles (module docstring); quick: two runs each."""
    runs = 2 if quick else RUNS
    out: dict[str, Any] = {'law': LAW, 'runs': runs, 'scenes': {}}
    with tempfile.TemporaryDirectory(prefix='pam_bench_plugin_') as tmp:
        site = pathlib.Path(tmp) / 'site'
        subprocess.run([sys.executable, '-m', 'pip', 'install', '-q', '--no-deps',
                        '--no-build-isolation', '--target', str(site),
                        str(ROOT / 'examples' / 'pam_bench_example')],
                       check=True, capture_output=True, timeout=300)
        for scene in SCENES:
            times: dict[str, list[float]] = {'built_in': [], 'law': []}
            for i in range(runs + 1):
                for kind in ('built_in', 'law'):
                    bag = pathlib.Path(tmp) / f'{scene}_{kind}_{i}'
                    took = _run(site, scene, kind == 'law', bag)
                    if i:                                     # the first: the warm-up
                        times[kind].append(took)
            out['scenes'][scene] = times
    return out


def _medians(c: dict[str, Any], scene: str) -> tuple[float, float]:
    t = c['scenes'][scene]
    return statistics.median(t['built_in']), statistics.median(t['law'])


def section(r: dict[str, Any]) -> list[str]:
    """One row per scene: both muscles' times and the ratio of the medians."""
    c = r['plugin_law']
    rows: list[Row] = []
    for scene, t in c['scenes'].items():
        b, law = _medians(c, scene)
        rows.append((scene, spread(t['built_in']), spread(t['law']), f'{law / b:.2f}x'))
    return table(['scene', "the bench's McKibben muscle", f"the example law ({c['law']})",
                  'ratio of the medians'], rows) + [
        '', f"{c['runs']} runs each, alternated, after one warm-up run of each."]


def results(r: dict[str, Any]) -> list[Row]:
    """The ratio per scene against the goal."""
    c = r.get('plugin_law')
    if not c:
        return []
    ratios = ', '.join(f'{s} {_medians(c, s)[1] / _medians(c, s)[0]:.2f}x' for s in c['scenes'])
    return [('the example plug-in law against the built-in muscle, `pam-bench run` wall time '
             '(median)', f'within {GOAL}x', ratios, commit_of(r, 'plugin_law'))]


STUDY = Study(
    'plugin_law', 'the example plug-in law against the built-in muscle: demo and '
    'campaign_quick, run for run',
    lambda quick, out, scenes: {'plugin_law': measure(quick)},
    (('plugin_law', lambda r, root: section(r)),), results, quick=False)
"""A lab's law, timed beside the built-in muscle (bench.json ``plugin_law``)."""
