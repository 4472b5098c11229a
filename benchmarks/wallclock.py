"""The bench on a wall clock: readings against lock-step, the 1 kHz servo's period, delivery.

Runs scenes with ``pam-bench run --wallclock`` (devices in the emulator process, controllers
and recorder in their own) and the same scene and seed in lock-step, and compares them reading
by reading (``verify.wallclock``). The torque servo runs ``servo_sin_t`` in several set-ups:
rclpy's timer and executor, the monotonic-deadline loop at ordinary priority, the same loop
SCHED_FIFO (the default), and the default with every device in its own process. Each row gives
the servo's period statistics (``analysis.timing``), its torque RMS error, the RMS difference
from the lock-step run's measured torque, and what the recorder lost (``analysis.delivery``).
"""

from __future__ import annotations

import copy
import dataclasses
import pathlib
from typing import Any

import numpy as np

from benchmarks.study import Study
from benchmarks.tables import Row, commit_of, table
from pam_bench.analysis.delivery import delivery_table
from pam_bench.bringup.runner import RunResult, run_scene
from pam_bench.config.scene import Scene, load_scene
from pam_bench.config.settings import LiveViewSettings
from pam_bench.verify.wallclock import compare_readings
from pam_bench.vocabulary.run import Layout, RunOptions

__all__ = ['STUDY', 'measure_wallclock', 'SERVO_SETUPS', 'wallclock_section', 'wallclock_results']

SERVO_SETUPS: tuple[tuple[str, dict[str, Any], bool, bool], ...] = (
    ('rclpy timer + executor', {'wall_loop': 'timer', 'realtime_priority': 0}, False, False),
    ('deadline loop, ordinary priority', {'realtime_priority': 0}, False, False),
    ('deadline loop, SCHED_FIFO 50 (default)', {}, False, False),
    ('default, every device its own process', {}, True, False),
    ('default, with the live view (--live)', {}, False, True),
)
"""(label, torque_servo parameters, device_processes, live view) of each servo row."""
QUICK_SETUPS = (2,)
"""``--quick``: the default set-up (the live view has its test in ``make test``)."""
QUICK_SERVO_S = 4.0
"""``--quick``: the servo's run, s (the scene's 8 s in the full run)."""


def _lost(res: RunResult) -> tuple[int, int]:
    """(messages lost, messages written) over the topics with one publisher."""
    if 'recorder' not in res.stats:
        return 0, 0
    rows = delivery_table({k: v for k, v in res.stats.items() if k != 'recorder'},
                          res.stats['recorder'])
    return (sum(r.lost or 0 for r in rows), sum(r.written for r in rows))


def _with(scene: Scene, node: str, params: dict[str, Any]) -> Scene:
    p = copy.deepcopy(scene.parameters)
    p.setdefault(node, {}).update(params)
    return dataclasses.replace(scene, parameters=p)


def _readings(name: str, out: pathlib.Path) -> dict[str, Any]:
    scene = load_scene(name)
    print(f'  {name}: lock-step, then wall clock ...', flush=True)
    lock = run_scene(scene, str(out / f'{name}_lock'),
                     RunOptions(layout=Layout.COMPOSED, quiet=True))
    wall = run_scene(scene, str(out / f'{name}_wall'),
                     RunOptions(layout=Layout.WALL_CLOCK, quiet=True))
    d = compare_readings(out / f'{name}_wall', out / f'{name}_lock')
    lost, written = _lost(wall)
    seq = wall.stats.get('sequencer', {}).get('periods', {})
    emu = wall.stats.get('valve_1', {}).get('periods', {})
    return {'scene': name, 'code': wall.code, 'lock_code': lock.code, 'wall_s': wall.wall_s,
            'matched': d.matched, 'unmatched': d.only_a + d.only_b,
            'max_force_n': d.max_force_n, 'max_contraction_mm': d.max_contraction_m * 1e3,
            'rms_force_n': d.rms_force_n, 'within_bounds': d.within_bounds,
            'lost': lost, 'written': written, 'sequencer_periods': seq,
            'device_periods': emu}


def _servo(out: pathlib.Path, quick: bool = False) -> list[dict[str, Any]]:
    from pam_bench.twin.servo_bench import tracking_metrics
    from pam_bench.twin.servo_setup import servo_run_of_bag
    scene = load_scene('servo_sin_t')
    if quick:
        scene = dataclasses.replace(scene, duration_s=QUICK_SERVO_S)
    print('  servo_sin_t: lock-step reference ...', flush=True)
    run_scene(scene, str(out / 'servo_lock'), RunOptions(layout=Layout.COMPOSED, quiet=True))
    ref = servo_run_of_bag(out / 'servo_lock', 2)
    rows = []
    for i, (label, params, separate, live) in enumerate(SERVO_SETUPS):
        if quick and i not in QUICK_SETUPS:
            continue
        print(f'  servo_sin_t on the wall clock: {label} ...', flush=True)
        bag = out / f'servo_wall_{i}'
        res = run_scene(_with(scene, 'torque_servo', params), str(bag),
                        RunOptions(layout=Layout.WALL_CLOCK, device_processes=separate,
                                   quiet=True, live=LiveViewSettings(port=0) if live else None))
        run = servo_run_of_bag(bag, 2)
        m = np.interp(ref.t_s, run.t_s, run.measured)
        keep = (ref.t_s >= 1.0) & (ref.t_s <= run.t_s[-1])
        lost, written = _lost(res)
        rows.append({'setup': label, 'code': res.code, 'duration_s': scene.duration_s,
                     'periods': res.stats.get('torque_servo', {}).get('periods', {}),
                     'device_periods': res.stats.get('valve_1', {}).get('periods', {}),
                     'rms_error_nm': tracking_metrics(run)['rms_error'],
                     'lockstep_rms_error_nm': tracking_metrics(ref)['rms_error'],
                     'rms_vs_lockstep_nm': float(np.sqrt(np.mean(
                         (m[keep] - ref.measured[keep]) ** 2))),
                     'lost': lost, 'written': written})
    return rows


def measure_wallclock(out: pathlib.Path, quick: bool) -> dict[str, Any]:
    """The wall-clock study (module docstring); ``quick`` runs the servo's ``QUICK_SETUPS``
    only, for ``QUICK_SERVO_S``: the readings on the wall clock (the demo, 17 s, and
    isometric_quick, 2 min) are in the full run, and `make test` compares the wall-clock
    readings with the lock-step ones at every run."""
    scenes = [] if quick else ['demo', 'isometric_quick']
    return {'readings': [_readings(n, out) for n in scenes], 'servo': _servo(out, quick)}


def _ms(x: float) -> str:
    return f'{x * 1e3:.3f}'


def wallclock_section(r: dict[str, Any]) -> list[str]:
    """The tables of the section."""
    w = r['wallclock']
    lines = ['Readings against the lock-step run of the same scene and seed:', '']
    if not w['readings']:
        lines = ['The readings on the wall clock are left out of a quick run.']
    else:
        lines += table(['scene', 'readings', 'max |dF|', 'RMS dF', 'max |dx|', 'within 10 N / '
                        '0.2 mm', 'recorder lost / written', 'wall s', 'sequencer p99 / late',
                        'devices p99 / late'],
                       [(row['scene'], row['matched'], f"{row['max_force_n']:.2f} N",
                         f"{row['rms_force_n']:.2f} N", f"{row['max_contraction_mm']:.4f} mm",
                         'yes' if row['within_bounds'] else 'no',
                         f"{row['lost']} / {row['written']}", f"{row['wall_s']:.1f}",
                         _per(row['sequencer_periods']), _per(row['device_periods']))
                        for row in w['readings']])
    seconds = w['servo'][0].get('duration_s', 8.0) if w['servo'] else 8.0
    lines += ['', f'The torque servo over `servo_sin_t` ({seconds:g} s) on the wall clock; '
              'periods in ms:', '']
    lines += table(['set-up', 'mean', 'p50', 'p99', 'max', 'late > 0.5 ms', 'torque RMS',
                    'RMS vs lock-step', 'devices p99 / late', 'recorder lost / written'],
                   [(row['setup'], _ms(row['periods'].get('mean_s', float('nan'))),
                     _ms(row['periods'].get('p50_s', float('nan'))),
                     _ms(row['periods'].get('p99_s', float('nan'))),
                     _ms(row['periods'].get('max_s', float('nan'))),
                     f"{row['periods'].get('late_share', float('nan')) * 100:.2f} %",
                     f"{row['rms_error_nm']:.4f} N m", f"{row['rms_vs_lockstep_nm']:.4f} N m",
                     _per(row['device_periods']), f"{row['lost']} / {row['written']}")
                    for row in w['servo']])
    ref = w['servo'][0]['lockstep_rms_error_nm'] if w['servo'] else float('nan')
    lines += ['', f'Lock-step torque RMS of the same scene: {ref:.4f} N m.']
    return lines


def _per(p: dict[str, float]) -> str:
    if not p:
        return '-'
    return f"{p['p99_s'] * 1e3:.2f} ms / {p['late_share'] * 100:.1f} %"


def wallclock_results(r: dict[str, Any], commit: str) -> list[Row]:
    """Key-result rows."""
    w = r.get('wallclock')
    if not w:
        return []
    rows: list[Row] = []
    for row in w['readings']:
        rows.append((f"`{row['scene']}` on the wall clock against lock-step",
                     'within 10 N / 0.2 mm', f"max {row['max_force_n']:.2f} N / "
                     f"{row['max_contraction_mm']:.3f} mm over {row['matched']} readings",
                     commit))
    default = next((s for s in w['servo'] if 'default' in s['setup']
                    and 'own process' not in s['setup']), None)
    if default:
        p = default['periods']
        rows.append(('servo_sin_t on the wall clock: control period p99, late share',
                     '<= 1.5 ms, < 1 %', f"{p['p99_s'] * 1e3:.2f} ms, "
                     f"{p['late_share'] * 100:.2f} %", commit))
        rows.append(('servo_sin_t on the wall clock: torque RMS error', '<= 0.1 N m',
                     f"{default['rms_error_nm']:.4f} N m ({default['rms_vs_lockstep_nm']:.4f}"
                     ' N m from the lock-step run)', commit))
        rows.append(('servo_sin_t on the wall clock: messages lost by the recorder', '0',
                     f"{default['lost']} of {default['written']}", commit))
    live = next((s for s in w['servo'] if 'live view' in s['setup']), None)
    if live:
        p = live['periods']
        rows.append(('servo_sin_t on the wall clock with --live: control period p99, late',
                     '<= 1.5 ms, < 1 %', f"{p['p99_s'] * 1e3:.2f} ms, "
                     f"{p['late_share'] * 100:.2f} %", commit))
    return rows


STUDY = Study(
    'wallclock', 'the bench on a wall clock: readings against lock-step, periods, the servo',
    lambda quick, out, scenes: {'wallclock': measure_wallclock(out, quick)},
    (('wallclock', lambda r, root: wallclock_section(r)),),
    lambda r: wallclock_results(r, commit_of(r, 'wallclock')))
"""The bench on a wall clock (bench.json ``wallclock``)."""
