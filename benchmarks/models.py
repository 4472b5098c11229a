"""Benchmark studies on speed against error: work-precision of the models, the ROS run's
exchange step, fidelity per scene, and the torque servo. Measured by ``measure``; rendered by
``benchmarks.report`` (tables) and ``plot_work_precision`` (a log-log PNG beside the report)."""

from __future__ import annotations

import dataclasses
import pathlib
import time
from typing import Any

import numpy as np

from benchmarks.fidelity import fidelity_table
from benchmarks.study import Study
from benchmarks.tables import RESULTS, Row, commit_of, pct, table
from benchmarks.work_precision import work_precision
from pam_bench.analysis.servo_bag import read_servo_states
from pam_bench.bags.bagread import read_bags
from pam_bench.bringup.runner import run_scene
from pam_bench.config.paths import config_dir
from pam_bench.config.scene import load_scene
from pam_bench.control.inverse import InverseModel
from pam_bench.verify.reference_check import FULL_SCALE_N
from pam_bench.vocabulary.run import RunOptions

__all__ = ['STUDY', 'measure', 'plot_work_precision']

def _ros_sweep(out: pathlib.Path, quick: bool) -> dict[str, Any]:
    """isometric_quick and servo_sin_t through the nodes at several exchange steps (the
    isometric scene on its 5 ms sub-steps where the exchange is longer)."""
    iso_steps = [3.0, 0.1, 0.01] if quick else [3.0, 0.5, 0.1, 0.02, 0.005]
    rows = []
    ref = None
    for h in reversed(iso_steps):
        sc = dataclasses.replace(load_scene('isometric_quick'), exchange_step_s=h)
        bag = out / f'iso_{h}'
        res = run_scene(sc, str(bag), RunOptions(quiet=True))
        f = read_bags([bag]).points['isometric_quick'].force_n
        ref = f if ref is None else ref
        rows.append({'scene': 'isometric_quick', 'exchange_step_s': h, 'wall_s': res.wall_s,
                     'real_time_factor': res.sim_s / res.wall_s,
                     'max_error': float(np.max(np.abs(f - ref))), 'unit': 'N',
                     'pct_fs': 100 * float(np.max(np.abs(f - ref))) / FULL_SCALE_N})
    dur = 1.0 if quick else 2.0
    sref: tuple[Any, Any] | None = None
    for h in (0.001, 0.002, 0.005):
        sc = dataclasses.replace(load_scene('servo_sin_t'), exchange_step_s=h, duration_s=dur)
        bag = out / f'servo_{h}'
        res = run_scene(sc, str(bag), RunOptions(quiet=True))
        s = read_servo_states(bag)
        t = s['t_s'] - s['t_s'][0]
        if sref is None:
            sref = (t, s['torque_measured'])
        m = np.interp(sref[0], t, s['torque_measured'])
        keep = sref[0] >= 0.3
        rows.append({'scene': f'servo_sin_t ({dur:g} s)', 'exchange_step_s': h,
                     'wall_s': res.wall_s, 'real_time_factor': res.sim_s / res.wall_s,
                     'max_error': float(np.max(np.abs(m - sref[1])[keep])), 'unit': 'N m',
                     'rms_tracking_error': float(np.sqrt(np.mean(
                         (s['torque_setpoint'] - s['torque_measured'])[t >= 0.3] ** 2))),
                     'pct_fs': None})
    return {'rows': rows}


def measure(quick: bool, out: pathlib.Path) -> dict[str, Any]:
    """Run the sections; ``out`` is a scratch folder for bags."""
    inverse = InverseModel.load(config_dir() / 'inverse_model.yaml')
    res: dict[str, Any] = {}
    print('work-precision of the models ...', flush=True)
    t0 = time.perf_counter()
    res['work_precision'] = work_precision(quick, inverse)
    print(f'  {time.perf_counter() - t0:.0f} s; fidelity per scene ...', flush=True)
    res['fidelity'] = fidelity_table(inverse)
    print('exchange step of the ROS run ...', flush=True)
    res['ros_exchange_step'] = _ros_sweep(out, quick)
    print('torque servo: controllers compared ...', flush=True)
    from pam_bench.bringup.servo_compare import compare_servo
    few = ['servo_sin_t', 'force_verify_20mm']
    res['servo'] = compare_servo(out / 'servo_twin', 'twin', few if quick else None)
    if not quick:
        res['servo'] += compare_servo(out / 'servo_ros', 'ros', ['servo_sin_t',
                                                                 'force_verify_20mm'])
    return res


def plot_work_precision(rows: list[dict[str, Any]], root: pathlib.Path) -> str:
    """Log-log plot of error against wall time per model into ``root``; returns its name."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    models = list(dict.fromkeys(r['model'] for r in rows))
    fig, axes = plt.subplots(1, len(models), figsize=(4 * len(models), 3.6))
    for ax, model in zip(np.atleast_1d(axes), models, strict=True):
        for scheme in dict.fromkeys(r['scheme'] for r in rows if r['model'] == model):
            sel = [r for r in rows if r['model'] == model and r['scheme'] == scheme
                   and np.isfinite(r['relative_error']) and r['relative_error'] > 0]
            if sel:
                ax.loglog([r['wall_s_per_sim_s'] for r in sel],
                          [r['relative_error'] for r in sel], 'o-', label=scheme)
        ax.axhline(1e-3, color='grey', lw=0.8, ls=':')
        ax.set_title(model)
        ax.set_xlabel('wall s per sim s')
        ax.grid(alpha=0.3, which='both')
        ax.legend(fontsize=7)
    np.atleast_1d(axes)[0].set_ylabel('relative error')
    name = 'bench_work_precision.png'
    fig.tight_layout()
    (root / RESULTS).mkdir(parents=True, exist_ok=True)
    fig.savefig(root / RESULTS / name, dpi=100)
    plt.close(fig)
    return f'{RESULTS}/{name}'


def work_precision_section(r: dict[str, Any], root: pathlib.Path) -> list[str]:
    """The work-precision plot and table."""
    wp = r['work_precision']
    fastest = [(model, f"{row['scheme']} at {row['step_s'] * 1e3:g} ms "
                       f"({row['relative_error']:.1e})" if row else 'none of the steps tried')
               for model, row in wp['fastest_within_0.1pct'].items()]
    return ([f"![work-precision]({plot_work_precision(wp['rows'], root)})", '']
            + table(['model', 'scheme', 'step', 'relative error', 'wall s / sim s'],
                    [(row['model'], row['scheme'], f"{row['step_s'] * 1e3:g} ms",
                      f"{row['relative_error']:.2e}", f"{row['wall_s_per_sim_s']:.4f}")
                     for row in wp['rows']])
            + ['', 'Fastest scheme within 0.1 %:', ''] + table(['model', 'scheme'], fastest)
            + ['', f"Exact ZOH of the valve against the closed form: largest relative error "
               f"{wp['zoh_max_relative_error']:.1e}."])


def fidelity_section(r: dict[str, Any], root: pathlib.Path) -> list[str]:
    """Each model option's change of what a scene measures."""
    return table(['scene', 'option', 'quantity', 'change', 'tolerance', 'within', 'wall s',
                  'speed-up'],
                 [(row['scene'], row['option'], row['quantity'],
                   f"{row['change']:.3g} {row['unit']}", f"{row['tolerance']:g}",
                   'yes' if row['within'] else 'no', f"{row['wall_s']:.2f}",
                   f"{row['speed_up']:.2f}x") for row in r['fidelity']])


def ros_exchange_step_section(r: dict[str, Any], root: pathlib.Path) -> list[str]:
    """Scenes through the nodes at several exchange steps."""
    return table(['scene', 'exchange step', 'wall s', 'real-time factor', 'error', '% FS'],
                 [(row['scene'], f"{row['exchange_step_s'] * 1e3:g} ms",
                   f"{row['wall_s']:.1f}", f"{row['real_time_factor']:.2f}x",
                   f"{row['max_error']:.3f} {row['unit']}", pct(row['pct_fs']))
                  for row in r['ros_exchange_step']['rows']])


def servo_section(r: dict[str, Any], root: pathlib.Path) -> list[str]:
    """The torque servo's tracking per scene and controller."""
    return table(['scene', 'controller', 'engine', 'RMS error', 'max', 'at reversal',
                  'elsewhere', 'real-time factor'],
                 [(row['scene'], row['controller'], row['engine'],
                   f"{row['rms_error']:.3f} {row['unit']}", f"{row['max_error']:.3f}",
                   f"{row['error_at_reversal']:.3f}", f"{row['error_elsewhere']:.3f}",
                   f"{row['real_time_factor']:.2f}x") for row in r['servo']])


def results(r: dict[str, Any]) -> list[Row]:
    """The exact ZOH against its closed form, servo_sin_t's torque RMS."""
    rows: list[Row] = []
    wp = r.get('work_precision')
    if wp:
        rows.append(('exact ZOH of the valve against its closed form', '<= 1e-12 relative',
                     f"{wp['zoh_max_relative_error']:.1e}", commit_of(r, 'work_precision')))
    for row in r.get('servo', []):
        if row['scene'] == 'servo_sin_t' and row['controller'] == 'dynamic_inverse_pid':
            rows.append((f"servo_sin_t torque RMS, dynamic inverse + PID ({row['engine']})",
                         '-', f"{row['rms_error']:.3f} {row['unit']} at "
                         f"{row['real_time_factor']:.2f}x real time", commit_of(r, 'servo')))
    return rows


STUDY = Study('models', 'work-precision, model options, exchange steps through the nodes, '
              'the servo', lambda quick, out, scenes: measure(quick, out),
              (('work_precision', work_precision_section), ('fidelity', fidelity_section),
               ('ros_exchange_step', ros_exchange_step_section), ('servo', servo_section)),
              results)
"""The models' numerics (bench.json ``work_precision``, ``fidelity``, ``ros_exchange_step``,
``servo``)."""
