"""`pam-bench bench`: one run on this machine -> BENCHMARKS.md and bench.json.

Sections (each measured in the same run, with machine, date and commit):
- calibration of the simulated bench against the 004 figures;
- lock-step rate of the demo scene (separate processes) next to the rclpy ping-pong rate;
- exchange step against error: the numpy bench (same coupling as the nodes) at coarse and
  adaptive steps against a fixed 1 ms exchange, per protocol kind;
- protocol scenes through separate-process nodes: wall time and real-time factor;
- extraction: the scene bags against `pam-bench truth`, and the step identification's speed
  on the full step-response grid (680 records simulated on the quasi-static bench).
"""

from __future__ import annotations

import datetime
import json
import os
import pathlib
import platform
import subprocess
import tempfile
import time
from typing import Any

import numpy as np

from pam_bench.benchmarks import sections as bench_sections
from pam_bench.benchmarks.pingpong import pingpong_rate
from pam_bench.benchmarks.record_exchange import record_exchange_table
from pam_bench.benchmarks.report import render
from pam_bench.bringup.runner import run_scene
from pam_bench.config.scene import load_scene
from pam_bench.verify.calibration import calibration_figures
from pam_bench.verify.reference_check import FULL_SCALE_N, run_against_twin, series_readings

__all__ = ['run_benchmarks', 'render_report', 'exchange_step_error', 'STUDIES']

# (exchange step s, sub-step s) of the rows; the first is the characterisation scenes' own
SCENE_STEPS = (3.0, 0.005)
EXCHANGE_ROWS = [SCENE_STEPS, (3.0, 0.001), (3.0, 0.01), (0.1, 0.005), (0.01, 0.005)]


def exchange_step_error(quick: bool) -> list[dict[str, Any]]:
    """Error of settled readings against 1 ms exchanges on 1 ms sub-steps, per protocol kind,
    exchange step and sub-step (numpy twin: the sequencer's exchange steps and requests)."""
    du = 0.5 if quick else 0.1
    volts = list(np.round(np.arange(0.0, 6.0 + 1e-9, du), 9))
    volts = volts + volts[::-1]
    dF = 100.0 if quick else 10.0
    forces = list(np.arange(50.0, 950.0 + 1e-9, dF))
    forces = forces + forces[::-1]
    cases = [('isometric', 0.0, volts), ('isometric', 0.04, volts), ('isotonic', 500.0, volts),
             ('isotonic', 50.0, volts), ('isobaric', 4.0, forces)]
    rows = []
    for kind, value, swept in cases:
        ref, _, wall_ref = series_readings(kind, value, swept, 0.001, 0.001)
        for h, sub in EXCHANGE_ROWS[:3] if quick else EXCHANGE_ROWS:
            out, spr, wall = series_readings(kind, value, swept, h, sub)
            err = np.abs(out - ref)
            unit = 'N' if kind == 'isometric' else 'mm'
            scale = 1.0 if kind == 'isometric' else 1e3
            rows.append({'protocol': kind, 'held': value, 'exchange_step_s': h,
                         'sub_step_s': sub, 'exchanges_per_reading': spr,
                         'max_error': float(err.max() * scale), 'unit': unit,
                         'max_error_pct_fs': (float(err.max() / FULL_SCALE_N * 100)
                                              if kind == 'isometric' else None),
                         'wall_s': wall, 'wall_s_1ms': wall_ref})
    return rows


def _scene_run(name: str, out: pathlib.Path, one_process: bool = False) -> dict[str, Any]:
    t0 = time.perf_counter()
    bag = out / f'{name}{"_one" if one_process else ""}'
    res = run_scene(load_scene(name), str(bag), quiet=True, one_process=one_process)
    wall = time.perf_counter() - t0
    row = {'scene': name, 'code': res.code, 'exchange_steps': res.steps, 'sim_s': res.sim_s,
           'wall_s_lockstep': res.wall_s, 'wall_s_total': wall,
           'real_time_factor': res.sim_s / res.wall_s if res.wall_s else 0.0,
           'lockstep_rate_steps_per_s': res.rate}
    if 'deliveries' in res.stats and res.steps:
        # the messages to subscriptions per exchange: the same nodes and topics in separate
        # processes, where each is a DDS delivery (clock ticks and acknowledgements included)
        row['deliveries_per_exchange'] = res.stats['deliveries'] / res.steps
    return row


def _extraction(out: pathlib.Path, names: list[str], quick: bool) -> dict[str, Any]:
    """Extract each recorded scene bag, compare with its truth; time 680 step fits."""
    from pam_bench.analysis.errors import BagError
    from pam_bench.analysis.extract import extract
    from pam_bench.twin.quasistatic import QuasiStaticBench
    from pam_bench.verify.truth import compare, scene_schedule, truth_summary
    rows = []
    for name in names:
        try:
            summary = extract([str(out / name)], str(out / f'{name}_x'), figures=False)
        except (BagError, ValueError) as exc:
            rows.append({'scene': name, 'error': str(exc)})
            continue
        cmp = compare(truth_summary(name), summary)
        row: dict[str, Any] = {'scene': name}
        for suffix in ('', '_reference'):
            if cmp.get(f'isometric_gain{suffix}'):
                row[f'isometric_gain{suffix}_max_abs_rel_error'] = max(
                    abs(r['rel_error']) for r in cmp[f'isometric_gain{suffix}'])
            if f'isotonic_gain{suffix}' in cmp:
                row[f'isotonic_gain{suffix}_max_rel_error'] = (
                    cmp[f'isotonic_gain{suffix}']['max']['rel_error'])
            if f'isobaric_hysteresis{suffix}' in cmp:
                row[f'isobaric_hysteresis{suffix}_rel_error'] = (
                    cmp[f'isobaric_hysteresis{suffix}']['rel_error'])
        for key in ('step_fits', 'step_reference_fits'):
            if cmp.get(key):
                for c in 'bcd':
                    row[f'{key}_{c}_max_abs_rel_error'] = max(
                        abs(r[f'{c}_rel_error']) for r in cmp[key])
        rows.append(row)
    # identification speed on the full 17 x 40 grid (every 10th record with --quick), and the
    # extraction of a bag the size of the full campaign's (its points settled on the
    # quasi-static bench, 0.2 N / 5 um noise)
    from pam_bench.analysis.bagwrite import write_bag
    readings = [r for r in scene_schedule('step_response') if r.record_s > 0]
    if quick:
        readings = readings[::10]
    q, rng, recs = QuasiStaticBench(), np.random.default_rng(0), []
    points = []
    for r in scene_schedule('campaign_quick' if quick else 'campaign'):
        if r.record_s > 0:
            continue
        s = q.settle(r)
        points.append({'protocol': r.protocol, 'series': r.series, 'step': r.step,
                       'direction': int(r.direction), 'series_value': r.series_value,
                       'set_value': r.set_value, 'voltage': s.voltage_v,
                       'force': s.force_n + rng.normal(0.0, 0.2),
                       'contraction': s.contraction_m + rng.normal(0.0, 5e-6),
                       'pressure': s.pressure_pa})
    for r in readings:
        force = q.step_response(r.load_value, r.pre_voltage_v or 0.0, r.voltage_v, r.record_s,
                                r.sample_period_s) + rng.normal(0.0, 0.2, 1000)
        recs.append({'series': r.series, 'step': r.step, 'direction': int(r.direction),
                     'contraction': r.load_value, 'voltage_initial': r.pre_voltage_v,
                     'voltage_final': r.voltage_v, 'sample_period': r.sample_period_s,
                     'force': force})
    write_bag(out / 'steps', [], recs)
    t0 = time.perf_counter()
    fitted = extract([str(out / 'steps')], str(out / 'steps_x'), figures=False)
    steps_s = time.perf_counter() - t0
    write_bag(out / 'campaign_like', points, recs)
    t0 = time.perf_counter()
    extract([str(out / 'campaign_like')], str(out / 'campaign_like_x'), figures=True)
    return {'scenes': rows, 'identification': {
        'records': len(recs), 'fits_s': fitted['timing_s']['identification'],
        'extract_s': steps_s, 'workers': os.cpu_count(),
        'campaign_points': len(points), 'campaign_extract_s': time.perf_counter() - t0}}


def _commit() -> str:
    try:
        return subprocess.run(['git', 'rev-parse', '--short', 'HEAD'], capture_output=True,
                              text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return 'unknown'


def _layouts(out: pathlib.Path, quick: bool) -> dict[str, Any]:
    """The same scenes in both layouts, next to the ping-pong floor measured with them."""
    pp = pingpong_rate(3000)
    from pam_bench.benchmarks.pingpong import fanout_rate
    fanout = {}
    for n in (1, 7) if quick else (1, 7, 10):
        print(f'  lock-step with no work, {n} participants ...', flush=True)
        fanout[str(n)] = fanout_rate(n, 2000)
    rows = []
    for name in ('demo', 'servo_sin_t', 'campaign_quick') + (() if quick else ('campaign',)):
        for one in (False, True):
            print(f'  {name}, {"one process" if one else "separate processes"} ...', flush=True)
            row = _scene_run(name, out, one_process=one)
            row['layout'] = 'one process' if one else 'separate processes'
            if name.startswith('servo'):
                from pam_bench.benchmarks.servo_compare import servo_run_of_bag
                from pam_bench.twin.servo_bench import tracking_metrics
                run = servo_run_of_bag(out / f'{name}{"_one" if one else ""}', 2)
                row['torque_rms_error_nm'] = tracking_metrics(run)['rms_error']
            row['round_trips_per_exchange'] = pp / row['lockstep_rate_steps_per_s'] \
                if row['lockstep_rate_steps_per_s'] else None
            rows.append(row)
    return {'pingpong_round_trips_per_s': pp, 'fanout_exchanges_per_s': fanout, 'rows': rows}


def _servo_compare_nodes(out: pathlib.Path, quick: bool) -> dict[str, Any]:
    """`make servo-compare`: every servo scene x controller through the composed nodes, one
    job per CPU; its wall time and rows (quick: servo_sin_t, 2 s runs)."""
    from pam_bench.benchmarks.servo_compare import compare_servo
    jobs = os.cpu_count() or 1
    t0 = time.perf_counter()
    rows = compare_servo(out / 'servo_compare', 'ros', ['servo_sin_t'] if quick else None,
                         2.0 if quick else None, one_process=True, jobs=jobs)
    return {'wall_s': time.perf_counter() - t0, 'jobs': jobs, 'runs': len(rows),
            'sim_s': sum(r['sim_s'] for r in rows), 'rows': rows}


def _profiles(out: pathlib.Path, quick: bool) -> list[dict[str, Any]]:
    """servo_sin_t (2 s) in both layouts and campaign_quick composed, profiled."""
    from pam_bench.benchmarks.profile import profile_scene
    runs = [('servo_sin_t', 2.0, True), ('servo_sin_t', 2.0, False)]
    if not quick:
        runs.append(('campaign_quick', 0.0, True))
    return [profile_scene(name, dur, one) for name, dur, one in runs]


def _measure(name: str, quick: bool, out: pathlib.Path, scenes: list[str] | None,
             report: dict[str, Any]) -> None:
    """Run study ``name`` into ``report`` (its key, or the keys it fills)."""
    campaign = 'campaign_quick' if quick else 'campaign'
    names = scenes or [campaign]
    if name == 'calibration':
        from pam_bench.verify.figures_004 import figure_rows, measure_004
        measured = measure_004()
        report['calibration'] = {**calibration_figures(), 'figures_004': figure_rows(measured),
                                 'secant_004': measured['isometric_gain_secant_by_x'],
                                 'isotonic_min_at': [measured['isotonic_gain_min_u'],
                                                     measured['isotonic_gain_min_f']]}
    elif name == 'calibrate':
        from pam_bench.benchmarks.calibrate import measure_round_trips
        report['calibrate'] = measure_round_trips(quick)
    elif name == 'calibrate_nodes':
        from pam_bench.benchmarks.calibrate_nodes import measure_nodes_round_trip
        report['calibrate_nodes'] = measure_nodes_round_trip(out / 'calibrate_nodes')
    elif name == 'lockstep':
        pp = pingpong_rate(3000)
        demo = _scene_run('demo', out)
        report['lockstep'] = {'pingpong_round_trips_per_s': pp,
                              'demo_lockstep_steps_per_s': demo['lockstep_rate_steps_per_s'],
                              'ratio_lockstep_to_pingpong':
                                  demo['lockstep_rate_steps_per_s'] / pp,
                              'participants': 7, 'demo': demo}
    elif name == 'layouts':
        report['layouts'] = _layouts(out, quick)
    elif name == 'profile':
        report['profile'] = _profiles(out, quick)
    elif name == 'exchange_step':
        report['exchange_step'] = exchange_step_error(quick)
    elif name == 'record_exchange':
        report['record_exchange'] = record_exchange_table(quick)
    elif name == 'scenes':
        report['scenes'] = [_scene_run(n, out) for n in names]
        if campaign in names:
            print(f'{campaign} against its numpy twin (scene steps, then 1 ms) ...', flush=True)
            report['campaign'] = {'scene': campaign, 'twin_same_steps': run_against_twin(
                out / campaign, campaign, *SCENE_STEPS), 'twin_1ms': run_against_twin(
                out / campaign, campaign, 0.001, 0.001)}
        print('extraction against truth, identification speed ...', flush=True)
        report['extraction'] = _extraction(out, names, quick)
    elif name == 'models':
        report.update(bench_sections.measure(quick, out))
    elif name == 'faults':
        from pam_bench.benchmarks.faults import measure_faults
        report['faults'] = measure_faults(out)
    elif name == 'straight_fibre':
        from pam_bench.benchmarks.straight_fibre import measure_straight_fibre
        report['straight_fibre'] = measure_straight_fibre(out)
    elif name == 'servo_compare':
        report['servo_compare'] = _servo_compare_nodes(out, quick)
    elif name == 'wallclock':
        from pam_bench.benchmarks.wallclock import measure_wallclock
        report['wallclock'] = measure_wallclock(out, quick)


STUDIES = ('calibration', 'lockstep', 'layouts', 'profile', 'exchange_step', 'record_exchange',
           'scenes', 'models', 'wallclock', 'faults', 'straight_fibre', 'calibrate',
           'calibrate_nodes', 'servo_compare')
"""The studies of `pam-bench bench`, in the order they run; ``--only`` picks some."""
FILLS = {'scenes': ('scenes', 'campaign', 'extraction'),
         'models': ('work_precision', 'fidelity', 'ros_exchange_step', 'servo')}


def run_benchmarks(quick: bool, root: pathlib.Path, scenes: list[str] | None = None,
                   only: list[str] | None = None) -> dict[str, Any]:
    """Run the benchmarks and write BENCHMARKS.md and bench.json into ``root``.

    With ``only`` just those studies run; their figures replace the same keys of an existing
    bench.json and every key records the commit and date it was measured at (``measured``).

    Raises:
        ValueError: an unknown study in ``only``.
    """
    unknown = sorted(set(only or ()) - set(STUDIES))
    if unknown:
        raise ValueError(f'unknown study {unknown[0]!r}; known: {", ".join(STUDIES)}')
    now = datetime.datetime.now(datetime.UTC).isoformat(timespec='seconds')
    head = {'machine': {'platform': platform.platform(), 'cpus': os.cpu_count(),
                        'python': platform.python_version()},
            'date': now, 'commit': _commit(), 'quick': quick}
    path = root / 'bench.json'
    report: dict[str, Any] = {}
    if only and path.exists():
        report = json.loads(path.read_text(encoding='utf-8'))
        old = {'commit': report.get('commit', 'unknown'), 'date': report.get('date', ''),
               'quick': report.get('quick', False)}
        measured = report.setdefault('measured', {})
        for key in report:                    # figures of an earlier run keep its commit
            if key not in head and key != 'measured' and key not in measured:
                measured[key] = dict(old)
    else:
        report['measured'] = {}
    report.update(head)
    with tempfile.TemporaryDirectory(prefix='pam_bench_bench_') as tmp:
        out = pathlib.Path(tmp)
        for name in only or STUDIES:
            print(f'{name} ...', flush=True)
            _measure(name, quick, out, scenes, report)
            for key in FILLS.get(name, (name,)):
                report['measured'][key] = {'commit': head['commit'], 'date': now,
                                           'quick': quick}
    path.write_text(json.dumps(report, indent=2) + '\n', encoding='utf-8')
    render_report(root)
    return report


def render_report(root: pathlib.Path) -> pathlib.Path:
    """Write BENCHMARKS.md from ``root``/bench.json (and docs/long_runs.md); return its path.

    Raises:
        FileNotFoundError: no bench.json in ``root``.
    """
    report = json.loads((root / 'bench.json').read_text(encoding='utf-8'))
    md = root / 'BENCHMARKS.md'
    md.write_text(render(report, root), encoding='utf-8')
    return md
