"""`pam-bench servo-compare`: every servo scene with each controller -> metrics.json and plots.

Engines: ``ros`` runs each scene through the separate-process nodes and reads the servo's
state from the bag; ``twin`` runs the same models and the same controller exchange for
exchange in one process (``pam_bench.twin.servo_bench``), seconds instead of minutes. Metrics
(``servo_bench.tracking_metrics``): RMS and max error after the first second, and the largest
error in the window after each reversal of the set point's derivative (or square-wave jump)
against the largest elsewhere.
"""

from __future__ import annotations

import dataclasses
import json
import pathlib
import tempfile
import time
from typing import Any, NotRequired

import numpy as np

from pam_bench.config.scene import Scene, load_scene, scene_names
from pam_bench.control.torque_servo import ServoMode
from pam_bench.twin.servo_bench import ServoRun, Tracking, run_servo, tracking_metrics
from pam_bench.twin.servo_setup import scene_servo_setup, servo_run_of_bag
from pam_bench.vocabulary.run import ENGINES, Layout

__all__ = ['servo_scenes', 'scene_with', 'Sets', 'compare_servo', 'one_run', 'forward_model_rms',
           'ServoRow']


class ServoRow(Tracking):
    """One run of a comparison, as metrics.json holds it: the scene, the controller, the
    engine, how it tracked (``Tracking``), its sim and wall seconds and their ratio, and, for a
    single-muscle run with an inverse model, 004's forward model's RMS against the measured
    force (N; absent otherwise)."""

    scene: str
    controller: str
    engine: str
    sim_s: float
    wall_s: float
    real_time_factor: float
    forward_model_rms_N: NotRequired[float]


def servo_scenes() -> list[str]:
    """Scenes that run the torque servo node."""
    return [n for n in scene_names() if 'torque_servo' in load_scene(n).nodes]


Sets = tuple[tuple[str, Any], ...]
"""Settings set over each scene by path (``--set PATH=VALUE``), values parsed."""


def scene_with(name: str, sets: Sets = ()) -> Scene:
    """The scene ``name`` with ``sets`` applied (``Scene.set``).

    Raises:
        ConfigError: an unknown setting or a bad value (named).
    """
    scene = load_scene(name)
    for path, value in sets:
        scene.set(path, value)
    return scene


def _ros_run(scene: Scene, controller: str, duration_s: float | None,
             tmp: pathlib.Path, layout: Layout = Layout.PROCESSES
             ) -> tuple[ServoRun, float, float]:
    from pam_bench.bringup.runner import run_scene
    from pam_bench.vocabulary.run import RunOptions
    params = {k: dict(v) for k, v in scene.parameters.items()}
    params.setdefault('torque_servo', {})['controller'] = controller
    sc = dataclasses.replace(scene, parameters=params,
                             duration_s=duration_s or scene.duration_s)
    out = tmp / f'{scene.name}_{controller}'
    from pam_bench.cluster.layer import worker_domain
    res = run_scene(sc, str(out),
                    RunOptions(layout=layout,
                               quiet=True, domain_id=worker_domain()))
    if res.code != 0:
        raise RuntimeError(f'scene {scene.name} ({controller}) failed: exit {res.code}')
    return servo_run_of_bag(out, 2 if 'valve_2' in scene.nodes else 1), res.wall_s, res.sim_s


def compare_servo(out_dir: pathlib.Path, engine: str = 'twin', scenes: list[str] | None = None,
                  duration_s: float | None = None, layout: Layout = Layout.COMPOSED,
                  cluster: dict[str, Any] | None = None,
                  controllers: list[str] | None = None, sets: Sets = ()) -> list[ServoRow]:
    """Run every scene x controller (the built-ins, then ``controllers``: plug-ins' names);
    write out_dir/metrics.json and one PNG per scene.

    ``engine``: 'twin' (the numpy twin) or 'ros' (the nodes; composed in one process with
    ``Layout.COMPOSED``, which gives the same bags faster). The runs are jobs of the execution
    layer (``cluster.layer``; ``cluster``: ``connect``'s keywords), each ROS run on its worker's
    own domain. ``sets``: settings set over every scene, as ``run --set`` does. A run that
    fails is reported and left out of the metrics; the others complete.

    Raises:
        ValueError: an engine other than 'twin' or 'ros'.
    """
    if engine not in ENGINES:
        raise ValueError(f"engine {engine!r}: one of {', '.join(ENGINES)}")
    from pam_bench.cluster.layer import run_jobs
    label = 'ros, composed' if engine == 'ros' and layout is Layout.COMPOSED else engine
    out_dir.mkdir(parents=True, exist_ok=True)
    names = scenes or servo_scenes()
    ctls = [m.value for m in ServoMode] + [c for c in controllers or []
                                           if c not in {m.value for m in ServoMode}]
    tasks = [(name, ctl) for name in names for ctl in ctls]
    results: dict[tuple[str, str], tuple[ServoRun, float, float]] = {}
    with tempfile.TemporaryDirectory(prefix='pam_bench_servo_') as tmp:
        jobs = [(engine, name, ctl, duration_s, tmp, layout, sets) for name, ctl in tasks]
        for r in run_jobs(_one_job, jobs, label=f'servo-compare ({label})',
                          ros=engine == 'ros', **(cluster or {})):
            if r.ok:
                results[r.item[1], r.item[2]] = r.value
            else:
                print(f'{r.item[1]}: {r.item[2]}: error: {r.error}', flush=True)
    rows: list[ServoRow] = []
    for name in names:
        setup = scene_servo_setup(scene_with(name, sets))
        runs = {}
        for ctl in ctls:
            if (name, ctl) not in results:
                continue
            run, wall, sim = results[name, ctl]
            runs[ctl] = run
            row = ServoRow(**tracking_metrics(run), scene=name, controller=ctl, engine=label,
                           sim_s=sim, wall_s=wall, real_time_factor=sim / wall if wall else 0.0)
            forward = forward_model_rms(run, setup)
            if forward is not None:
                row['forward_model_rms_N'] = forward
            rows.append(row)
        if runs:
            _plot(name, runs, out_dir)
    (out_dir / 'metrics.json').write_text(json.dumps(rows, indent=2) + '\n', encoding='utf-8')
    return rows


def _one_job(job: tuple[str, str, str, float | None, str, Layout, Sets]
             ) -> tuple[ServoRun, float, float]:
    engine, name, ctl, duration_s, tmp, layout, sets = job
    return one_run(engine, name, ctl, duration_s, tmp, layout, sets)


def one_run(engine: str, name: str, ctl: str, duration_s: float | None, tmp: str,
            layout: Layout, sets: Sets = ()) -> tuple[ServoRun, float, float]:
    """One scene (``sets`` applied) with one controller: (its run, wall s, sim s)."""
    scene = scene_with(name, sets)
    t0 = time.perf_counter()
    if engine == 'ros':
        return _ros_run(scene, ctl, duration_s, pathlib.Path(tmp), layout)
    setup = scene_servo_setup(scene)
    sim = duration_s or scene.duration_s
    run = run_servo(ctl, setup['signal'], sim, setup['angle_rad'], scene.exchange_step_s,
                    setup['inverse'], setup['muscles'], setup['params'], setup['valve'],
                    setup['muscle'], plugins=setup['plugins'])
    return run, time.perf_counter() - t0, sim


def forward_model_rms(run: ServoRun, setup: dict[str, Any], settle_s: float = 1.0
                      ) -> float | None:
    """004's model check (issue 18): the identified forward model (004 Eq. 4) driven by the
    run's own voltage against the measured force, RMS after ``settle_s`` (N); single-muscle
    runs with an inverse model only (None otherwise)."""
    inverse = setup.get('inverse')
    if setup.get('muscles') != 1 or inverse is None or len(run.t_s) < 3:
        return None
    u = np.asarray(run.voltage_v, float).reshape(len(run.t_s), -1)[:, 0]
    f = np.asarray(run.force_n, float).reshape(len(run.t_s), -1)[:, 0]
    x = setup['params'].rest_contraction_m + setup['params'].pitch_diameter_m / 2 * setup[
        'angle_rad']
    model = inverse.forward_force(u, float(run.t_s[1] - run.t_s[0]), x, float(f[0]))
    keep = run.t_s >= settle_s
    return float(np.sqrt(np.mean((model - f)[keep] ** 2)))


def _plot(name: str, runs: dict[str, ServoRun], out_dir: pathlib.Path) -> None:
    """Set point, measured and error of each controller (004 figure style); dashed lines
    mark the reversals of the set point's derivative (004 section 4: the largest error sits
    there)."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    from pam_bench.twin.servo_bench import reversals
    fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    first = next(iter(runs.values()))
    for ax in axes:
        for m in reversals(first):
            ax.axvline(m, color='0.5', ls='--', lw=0.8)
    axes[0].plot(first.t_s, first.setpoint, 'k-', lw=1.5, label='set point')
    for ctl, run in runs.items():
        axes[0].plot(run.t_s, run.measured, lw=0.9, label=ctl)
        axes[1].plot(run.t_s, run.setpoint - run.measured, lw=0.9, label=ctl)
    axes[0].set_ylabel(f'{"torque" if first.unit == "N m" else "force"}, {first.unit}')
    axes[1].set_ylabel(f'error, {first.unit}')
    axes[1].set_xlabel('t, s')
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    axes[0].set_title(name)
    fig.tight_layout()
    fig.savefig(out_dir / f'{name}.png', dpi=110)
    plt.close(fig)
