"""Study ``limits``: the bench beside its limits, measured in the same run (issue 54).

For each scene (demo, servo_sin_t, campaign_quick; the full run adds the campaign), one after
the other in one process:

- nodes: the scene through the composed nodes (``Layout.COMPOSED``, ``pam-bench run``'s
  default), the wall time of ``run_scene`` from its call to its return (the nodes' start-up
  in the process included, the interpreter's and the imports' not);
- twin: the same scene on the numpy twin, which runs the same models and the same sequencer
  without nodes or messages (``twin.protocol_run.run_scene``; the servo scenes through
  ``bringup.servo_compare.one_run`` with engine 'twin');
- bag alone: every message of the nodes' bag encoded and written again as the composed
  recorder does it, without the bench (``nodes.bag_floor.write_again``): the floor of any
  layout that records the same bag;
- physics alone: the twin's wall time times the share of its profiled time (cProfile, own
  time per function) that ``benchmarks.profile.cause_of`` puts under physics: the models,
  their compiled kernels, numpy and scipy.

The figures this issue moves are the ratios of the nodes to the twin and to the bag floor.
"""

from __future__ import annotations

import cProfile
import pathlib
import pstats
import tempfile
import time
from typing import Any

from benchmarks.profile import cause_of
from benchmarks.runs import scene_bag, scene_run
from benchmarks.study import Study
from benchmarks.tables import Row, commit_of, table
from pam_bench.config.scene import load_scene
from pam_bench.nodes.bag_floor import write_again
from pam_bench.vocabulary.run import Layout

__all__ = ['STUDY', 'SCENES', 'measure', 'twin_run_s', 'physics_share']

SCENES = ('demo', 'servo_sin_t', 'campaign_quick', 'campaign')
"""The scenes of the table; ``--quick`` leaves out the last."""


def _twin(name: str) -> None:
    """Scene ``name`` once on the numpy twin (module docstring)."""
    scene = load_scene(name)
    if 'torque_servo' in scene.nodes:
        from pam_bench.bringup.servo_compare import one_run
        controller = str(scene.settings()['torque_servo'].controller)
        with tempfile.TemporaryDirectory(prefix='pam_bench_limits_') as tmp:
            one_run('twin', name, controller, None, tmp, Layout.COMPOSED)
        return
    from pam_bench.twin.protocol_run import run_scene
    run_scene(scene)


def twin_run_s(name: str) -> float:
    """Wall seconds of scene ``name`` on the twin."""
    t0 = time.perf_counter()
    _twin(name)
    return time.perf_counter() - t0


def physics_share(name: str) -> float:
    """The share of the twin's profiled own time (cProfile) under physics (``cause_of``)."""
    prof = cProfile.Profile()
    prof.enable()
    try:
        _twin(name)
    finally:
        prof.disable()
    stats = pstats.Stats(prof)
    own: dict[str, float] = {}
    for (filename, _, function), row in stats.stats.items():   # type: ignore[attr-defined]
        cause = cause_of(filename, function)
        own[cause] = own.get(cause, 0.0) + row[2]
    total = sum(own.values())
    return own.get('physics', 0.0) / total if total > 0 else 0.0


def measure(quick: bool, out: pathlib.Path, scenes: list[str] | None) -> dict[str, Any]:
    """Each scene of ``SCENES`` (or ``scenes``) through the nodes, on the twin, its bag alone
    and its physics alone, one after the other (module docstring)."""
    names = scenes or list(SCENES[:-1] if quick else SCENES)
    rows = []
    for name in names:
        print(f'  {name}: nodes, twin, bag alone, physics ...', flush=True)
        run = scene_run(name, out, Layout.COMPOSED)
        twin_s = twin_run_s(name)
        bag_s, n = write_again(scene_bag(name, out, Layout.COMPOSED), out / f'{name}_bag_alone')
        share = physics_share(name)
        rows.append({'scene': name, 'code': run['code'], 'nodes_s': run['wall_s_total'],
                     'lockstep_s': run['wall_s_lockstep'], 'sim_s': run['sim_s'],
                     'twin_s': twin_s, 'bag_alone_s': bag_s, 'messages': n,
                     'physics_share_of_twin': share, 'physics_alone_s': share * twin_s})
    return {'limits': rows}


def section(r: dict[str, Any], root: pathlib.Path) -> list[str]:
    """The limit table: seconds and the two ratios."""
    return table(['scene', 'sim s', 'nodes (composed) s', 'twin s', 'bag alone s (messages)',
                  'physics alone s', 'nodes / twin', 'nodes / bag alone'],
                 [(row['scene'], f"{row['sim_s']:.1f}", f"{row['nodes_s']:.2f}",
                   f"{row['twin_s']:.2f}", f"{row['bag_alone_s']:.2f} ({row['messages']})",
                   f"{row['physics_alone_s']:.2f}",
                   f"{row['nodes_s'] / row['twin_s']:.1f}",
                   f"{row['nodes_s'] / row['bag_alone_s']:.1f}")
                  for row in r['limits']])


def results(r: dict[str, Any]) -> list[Row]:
    """The campaign's (else the last scene's) ratio of the nodes to the twin and the bag."""
    rows = r.get('limits') or []
    if not rows:
        return []
    row = next((x for x in rows if x['scene'] == 'campaign'), rows[-1])
    return [(f"{row['scene']} through the composed nodes / twin / bag alone",
             'the ratios issue 54 moves (nodes 2x faster)',
             f"{row['nodes_s']:.1f} / {row['twin_s']:.1f} / {row['bag_alone_s']:.1f} s",
             commit_of(r, 'limits'))]


STUDY = Study('limits', 'the composed nodes beside the twin, the bag alone and the physics '
              'alone, in one run', measure, (('limits', section),), results)
"""The limit table (bench.json ``limits``)."""
