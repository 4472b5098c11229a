"""One job of a sweep: its scene with its settings set, run on its engine, and its figures.

A protocol scene runs on the twin (``twin.protocol_run.run_scene``) or through the composed
nodes into a scratch bag; either way its readings and step records go through the extraction's
estimators (``analysis.static.gain_summary``, ``analysis.extract.step_summary``), so a figure
means what it means in summary.json. A servo scene runs on the servo twin
(``twin.servo_bench``) or through the nodes, and gives ``servo.*`` (``tracking_metrics``). A
``calibrate.*`` figure fits the bench to the run's own readings (``fit.calibrate_bags``).
Figures a run does not produce are NaN.
"""

from __future__ import annotations

import math
import pathlib
import tempfile
from typing import Any

from pam_bench.sweep.spec import Job

__all__ = ['run_job', 'figure_of']


def figure_of(result: dict[str, Any], key: str) -> float:
    """The number at the dotted ``key`` of ``result`` (list items by index), NaN when absent."""
    here: Any = result
    for part in key.split('.'):
        if isinstance(here, dict) and part in here:
            here = here[part]
        elif isinstance(here, list) and part.lstrip('-').isdigit() and \
                -len(here) <= int(part) < len(here):
            here = here[int(part)]
        else:
            return math.nan
    if isinstance(here, bool) or not isinstance(here, (int, float)):
        return math.nan
    return float(here)


def _scene(job: Job) -> Any:
    from pam_bench.config.scene import load_scene
    scene = load_scene(job.scene)
    for path, value in job.values:
        scene.set(path, value)
    return scene


def _protocol_result(scene: Any, job: Job, engine: str, figures: list[str]) -> dict[str, Any]:
    from pam_bench.analysis.extract import step_summary
    from pam_bench.analysis.static import gain_summary
    if engine == 'twin':
        from pam_bench.twin.protocol_run import bag_data_of, run_scene
        run = run_scene(scene, job.seed)
        data = bag_data_of(run)
        out: dict[str, Any] = {'run': {'sim_s': run.sim_s, 'exit_code': run.exit_code}}
    else:
        from pam_bench.bags.bagread import read_bags
        from pam_bench.bringup.runner import run_scene as run_nodes
        from pam_bench.cluster.layer import worker_domain
        from pam_bench.vocabulary.run import RunOptions
        with tempfile.TemporaryDirectory(prefix='pam_bench_sweep_') as tmp:
            bag = pathlib.Path(tmp) / 'bag'
            res = run_nodes(scene, str(bag),
                            RunOptions(seed=job.seed, quiet=True, domain_id=worker_domain()))
            data = read_bags([str(bag)])
        out = {'run': {'sim_s': res.sim_s, 'exit_code': res.code}}
    out.update(gain_summary(data.points))
    forces = [float(p.force_n.max()) for p in data.points.values() if len(p)]
    strokes = [float(p.contraction_m.max()) for p in data.points.values() if len(p)]
    out['readings'] = {'force_max_N': max(forces, default=math.nan),
                       'contraction_max_mm': max(strokes, default=math.nan) * 1e3}
    if data.records:
        out['step_response'] = step_summary(data.records)
    if any(f.startswith('calibrate.') for f in figures):
        from pam_bench.fit.calibrate_bags import (
            bench_of_settings,
            calibrate_bags,
            observations_from_bags,
        )
        fit = calibrate_bags(observations_from_bags(data),
                             *bench_of_settings(scene.settings(), f'scene {scene.name}'))
        out['calibrate'] = {k: fit[k] for k in ('values', 'stderr', 'rms_after', 'cost',
                                                'evaluations')}
    return out


def _servo_result(scene: Any, job: Job, engine: str, duration_s: float | None
                  ) -> dict[str, Any]:
    import dataclasses

    from pam_bench.twin.servo_bench import run_servo, tracking_metrics
    from pam_bench.twin.servo_setup import scene_servo_setup, servo_run_of_bag
    sim = duration_s or scene.duration_s
    st = scene.settings(seed=job.seed)
    if engine == 'twin':
        setup = scene_servo_setup(scene)
        run = run_servo(st['torque_servo'].controller, setup['signal'], sim,
                        setup['angle_rad'], scene.exchange_step_s, setup['inverse'],
                        setup['muscles'], setup['params'], st['valve_1'].valve,
                        st['muscle_1'].muscle, seed=job.seed, plugins=setup['plugins'])
        code = 0
    else:
        from pam_bench.bringup.runner import run_scene as run_nodes
        from pam_bench.cluster.layer import worker_domain
        from pam_bench.vocabulary.run import RunOptions
        with tempfile.TemporaryDirectory(prefix='pam_bench_sweep_') as tmp:
            bag = pathlib.Path(tmp) / 'bag'
            res = run_nodes(dataclasses.replace(scene, duration_s=sim), str(bag),
                            RunOptions(seed=job.seed, quiet=True, domain_id=worker_domain()))
            run = servo_run_of_bag(bag, 2 if 'valve_2' in scene.nodes else 1)
            code = res.code
    return {'servo': tracking_metrics(run), 'run': {'sim_s': sim, 'exit_code': code}}


def run_job(task: tuple[Job, str, list[str], float | None]) -> dict[str, float]:
    """Run one job (``task``: the job, the engine, the figures, a servo scene's duration) and
    return its figures (key -> number, NaN where the run does not give it).

    Raises:
        ConfigError: a setting of the job does not fit its scene.
    """
    job, engine, figures, duration_s = task
    scene = _scene(job)
    if 'torque_servo' in scene.nodes:
        result = _servo_result(scene, job, engine, duration_s)
    else:
        result = _protocol_result(scene, job, engine, figures)
    return {f: figure_of(result, f) for f in figures}
