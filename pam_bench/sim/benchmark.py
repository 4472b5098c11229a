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

from pam_bench.sim import bench_sections
from pam_bench.sim.calibration import calibration_figures
from pam_bench.sim.pingpong import pingpong_rate
from pam_bench.sim.record_exchange import record_exchange_table
from pam_bench.sim.reference_check import FULL_SCALE_N, series_readings
from pam_bench.sim.runner import run_scene
from pam_bench.sim.scene import load_scene

__all__ = ['run_benchmarks', 'exchange_step_error']

def exchange_step_error(quick: bool) -> list[dict[str, Any]]:
    """Error of settled readings against a fixed 1 ms exchange, per protocol kind and step
    (chained coupling, as the characterisation scenes run)."""
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
        ref, _, wall_ref = series_readings(kind, value, swept, 0.001, False)
        for h, adaptive, tr in ((0.01, False, None), (0.5, True, 0.02), (0.5, True, 0.01)):
            out, spr, wall = series_readings(kind, value, swept, h, adaptive, tr)
            err = np.abs(out - ref)
            unit = 'N' if kind == 'isometric' else 'mm'
            scale = 1.0 if kind == 'isometric' else 1e3
            rows.append({'protocol': kind, 'held': value, 'exchange_step_s': h,
                         'adaptive_transient_step_s': tr, 'exchanges_per_reading': spr,
                         'max_error': float(err.max() * scale), 'unit': unit,
                         'max_error_pct_fs': (float(err.max() / FULL_SCALE_N * 100)
                                              if kind == 'isometric' else None),
                         'wall_s': wall, 'wall_s_1ms': wall_ref})
    return rows


def _scene_run(name: str, out: pathlib.Path) -> dict[str, Any]:
    t0 = time.perf_counter()
    res = run_scene(load_scene(name), str(out / name), quiet=True)
    wall = time.perf_counter() - t0
    return {'scene': name, 'code': res.code, 'exchange_steps': res.steps, 'sim_s': res.sim_s,
            'wall_s_lockstep': res.wall_s, 'wall_s_total': wall,
            'real_time_factor': res.sim_s / res.wall_s if res.wall_s else 0.0,
            'lockstep_rate_steps_per_s': res.rate}


def _extraction(out: pathlib.Path, names: list[str], quick: bool) -> dict[str, Any]:
    """Extract each recorded scene bag, compare with its truth; time 680 step fits."""
    from pam_bench.analysis.bagread import BagError
    from pam_bench.analysis.extract import extract
    from pam_bench.sim.quasistatic import QuasiStaticBench
    from pam_bench.sim.truth import compare, scene_schedule, truth_summary
    rows = []
    for name in names:
        try:
            summary = extract([str(out / name)], str(out / f'{name}_x'), figures=False)
        except (BagError, ValueError) as exc:
            rows.append({'scene': name, 'error': str(exc)})
            continue
        cmp = compare(truth_summary(name), summary)
        row: dict[str, Any] = {'scene': name}
        if 'isometric_gain' in cmp:
            row['isometric_gain_max_abs_rel_error'] = max(
                abs(r['rel_error']) for r in cmp['isometric_gain'])
        if 'isotonic_gain' in cmp:
            row['isotonic_gain_max_rel_error'] = cmp['isotonic_gain']['max']['rel_error']
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
        force = q.step_response(r.load_value, r.pre_voltage_v, r.voltage_v, r.record_s,
                                r.sample_period_s) + rng.normal(0.0, 0.2, 1000)
        recs.append({'series': r.series, 'step': r.step, 'direction': int(r.direction),
                     'contraction': r.load_value, 'voltage_initial': r.pre_voltage_v,
                     'voltage_final': r.voltage_v, 'sample_period': r.sample_period_s,
                     'force': force})
    write_bag(out / 'steps', [], recs)
    t0 = time.perf_counter()
    s = extract([str(out / 'steps')], str(out / 'steps_x'), figures=False)
    steps_s = time.perf_counter() - t0
    write_bag(out / 'campaign_like', points, recs)
    t0 = time.perf_counter()
    extract([str(out / 'campaign_like')], str(out / 'campaign_like_x'), figures=True)
    return {'scenes': rows, 'identification': {
        'records': len(recs), 'fits_s': s['timing_s']['identification'],
        'extract_s': steps_s, 'workers': os.cpu_count(),
        'campaign_points': len(points), 'campaign_extract_s': time.perf_counter() - t0}}


def _commit() -> str:
    try:
        return subprocess.run(['git', 'rev-parse', '--short', 'HEAD'], capture_output=True,
                              text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return 'unknown'


def run_benchmarks(quick: bool, root: pathlib.Path, scenes: list[str] | None = None
                   ) -> dict[str, Any]:
    """Run the benchmarks and write BENCHMARKS.md and bench.json into ``root``."""
    report: dict[str, Any] = {
        'machine': {'platform': platform.platform(), 'cpus': os.cpu_count(),
                    'python': platform.python_version()},
        'date': datetime.datetime.now(datetime.UTC).isoformat(timespec='seconds'),
        'commit': _commit(), 'quick': quick}
    print('calibration ...', flush=True)
    report['calibration'] = calibration_figures()
    with tempfile.TemporaryDirectory(prefix='pam_bench_bench_') as tmp:
        out = pathlib.Path(tmp)
        print('ping-pong and demo lock-step ...', flush=True)
        pp = pingpong_rate(3000)
        demo = _scene_run('demo', out)
        report['lockstep'] = {'pingpong_round_trips_per_s': pp,
                              'demo_lockstep_steps_per_s': demo['lockstep_rate_steps_per_s'],
                              'ratio_lockstep_to_pingpong':
                                  demo['lockstep_rate_steps_per_s'] / pp,
                              'participants': 7, 'demo': demo}
        print('exchange step against error (numpy bench) ...', flush=True)
        report['exchange_step'] = exchange_step_error(quick)
        print('step records against the record exchange step (numpy bench) ...', flush=True)
        report['record_exchange'] = record_exchange_table(quick)
        names = scenes or (['isometric_quick', 'step_response_quick', 'isotonic_quick']
                           if quick else ['isometric', 'step_response_quick', 'isotonic_quick',
                                          'isobaric_quick'])
        report['scenes'] = []
        for name in names:
            print(f'scene {name} ...', flush=True)
            report['scenes'].append(_scene_run(name, out))
        print('extraction against truth, identification speed ...', flush=True)
        report['extraction'] = _extraction(out, names, quick)
        print('recorded readings against the 1 ms reference (numpy bench) ...', flush=True)
        report['recorded_vs_reference'] = bench_sections.recorded_against_reference(
            out, names, quick)
        report.update(bench_sections.measure(quick, out))
    (root / 'bench.json').write_text(json.dumps(report, indent=2) + '\n', encoding='utf-8')
    md = root / 'BENCHMARKS.md'
    kept = _long_runs(md.read_text(encoding='utf-8')) if md.exists() else ''
    md.write_text(render(report, root) + kept, encoding='utf-8')
    return report


def _long_runs(markdown: str) -> str:
    """The '## Long runs' section of an earlier BENCHMARKS.md (runs too long for `pam-bench
    bench`, written by hand from separate `pam-bench run` campaigns), kept across reruns."""
    start = markdown.find('\n## Long runs')
    if start < 0:
        return ''
    end = markdown.find('\n## ', start + 1)
    return '\n' + markdown[start:end if end > 0 else None].strip('\n') + '\n'


def render(r: dict[str, Any], root: pathlib.Path | None = None) -> str:
    """BENCHMARKS.md from a report."""
    c, ls = r['calibration'], r['lockstep']
    lines = [
        '# pam_bench benchmarks', '',
        f"Measured in one run of `pam-bench bench{' --quick' if r['quick'] else ''}` on "
        f"{r['machine']['platform']}, {r['machine']['cpus']} CPUs, Python "
        f"{r['machine']['python']}, {r['date']}, commit `{r['commit']}`. Raw figures: "
        '`bench.json`.', '',
        '## Calibration against 004', '',
        '| figure | simulated bench | 004 | tolerance |', '|---|---|---|---|',
        f"| isometric gain at x = 0 mm | {c['isometric_gain_N_per_V_at_0mm']:.1f} N/V | "
        '284.3 N/V | +-10 % |',
        f"| isometric gain at x = 95 mm | {c['isometric_gain_N_per_V_at_95mm']:.1f} N/V | "
        '17.4 N/V | +-30 % |',
        f"| contraction at 6 V, 50 N | {c['contraction_mm_at_6V_50N']:.1f} mm | >= 100 mm | - |",
        f"| force at 6 V, x = 0 | {c['force_N_at_6V_0mm']:.0f} N | >= 900 N | - |",
        f"| isobaric hysteresis, max | {c['isobaric_hysteresis_mm_max']:.2f} mm | visible | - |",
        '', '## Lock-step rate against the rclpy floor', '',
        '| measure | rate |', '|---|---|',
        f"| rclpy ping-pong, two processes | {ls['pingpong_round_trips_per_s']:.0f} round "
        'trips/s |',
        f"| lock-step, demo scene, {ls['participants']} participants in separate processes | "
        f"{ls['demo_lockstep_steps_per_s']:.0f} steps/s |",
        f"| ratio lock-step / ping-pong | {ls['ratio_lockstep_to_pingpong']:.3f} |", '',
        'Each exchange step costs every participant one /clock delivery, its inputs, its '
        'outputs and one acknowledgement; with seven Python processes on two cores the '
        'executor overhead per message, not the physics, sets the rate.', '',
        '## Exchange step against error', '',
        'The numpy bench couples the models exactly as the nodes do (the chained exchange of '
        'the characterisation scenes, the same step requests). Each row is one series of '
        'readings (0.1 V or 10 N steps, 3 s dwell) against the same series at a fixed 1 ms '
        'exchange; force errors are also given in % of the 2 kN full scale. At x = 0 the '
        'largest errors sit in the readings below the threshold pressure (u <= 0.2 V), where the '
        "braid's stuck residual force (about 15 N) survives only at exchange steps of 1 ms or "
        'less; the rest of that series is within 1.5 N. Isotonic at 50 N jumps near the '
        'threshold pressure, where any coupling lag moves the reading by tens of mm.', '',
        '| protocol | held | exchange step | adaptive transient step | exchanges per reading '
        '| max error | % FS | wall s (1 ms wall s) |', '|---|---|---|---|---|---|---|---|']
    for row in r['exchange_step']:
        fs = '' if row['max_error_pct_fs'] is None else f"{row['max_error_pct_fs']:.3f}"
        tr = row['adaptive_transient_step_s'] or 'fixed'
        lines.append(f"| {row['protocol']} | {row['held']:g} | {row['exchange_step_s']} s | "
                     f"{tr} | {row['exchanges_per_reading']:.1f} | {row['max_error']:.3f} "
                     f"{row['unit']} | {fs} | {row['wall_s']:.1f} ({row['wall_s_1ms']:.1f}) |")
    if r.get('record_exchange'):
        lines += ['', '## Step records', '',
                  'A 1 s record at 1 kHz after a valve step, taken with exchange steps H longer '
                  'than the sample period (chained coupling: the valve publishes its 1 ms '
                  'sub-steps, the muscle and the load cell follow each), against the same step '
                  'at the chained 1 ms exchange; b, c, d of 004 Eq. 2 fitted to both (numpy '
                  'bench, noise on, same seed).', '',
                  '| x mm | step | H | exchanges per record | largest b, c, d error | RMS force '
                  'difference | wall s (1 ms wall s) |', '|---|---|---|---|---|---|---|']
        for row in r['record_exchange']:
            lines.append(f"| {row['x_mm']:.0f} | {row['u0_V']:g} -> {row['u1_V']:g} V | "
                         f"{1e3 * row['record_exchange_s']:g} ms | {row['exchanges']} | "
                         f"{100 * row['max_abs_rel_error']:.2f} % | "
                         f"{row['rms_force_difference_N']:.2f} N | {row['wall_s']:.2f} "
                         f"({row['wall_s_1ms']:.2f}) |")
    lines += ['', '## Protocol scenes through separate-process nodes', '',
              '| scene | sim time | wall time | real-time factor | exchange steps | steps/s |',
              '|---|---|---|---|---|---|']
    for s in r['scenes']:
        lines.append(f"| {s['scene']} | {s['sim_s']:.0f} s | {s['wall_s_lockstep']:.1f} s | "
                     f"{s['real_time_factor']:.1f}x | {s['exchange_steps']} | "
                     f"{s['lockstep_rate_steps_per_s']:.0f} |")
    ex = r.get('extraction')
    if ex:
        lines += ['', '## Extraction against `pam-bench truth`', '',
                  "Each scene bag above extracted and compared with what the scene's parameters "
                  'imply (relative errors, largest over the series or records). Step fits are '
                  "compared twice: with the valve loop's b, c and the settled gain (`fits`), and "
                  'with the 2nd-order fit of the same step simulated noise-free at an ideal '
                  'position hold (`reference`).', '',
                  '| scene | isometric gain | isotonic max gain | step b, c, d vs parameters '
                  '| step b, c, d vs reference |', '|---|---|---|---|---|']
        for row in ex['scenes']:
            def pct(key: str, row: dict = row) -> str:
                return f'{100 * abs(row[key]):.1f} %' if key in row else '-'

            def bcd(prefix: str, row: dict = row) -> str:
                keys = [f'{prefix}_{c}_max_abs_rel_error' for c in 'bcd']
                if keys[0] not in row:
                    return '-'
                return ', '.join(f'{100 * row[k]:.0f} %' for k in keys)
            lines.append(f"| {row['scene']} | {pct('isometric_gain_max_abs_rel_error')} | "
                         f"{pct('isotonic_gain_max_rel_error')} | {bcd('step_fits')} | "
                         f"{bcd('step_reference_fits')} |")
        idf = ex['identification']
        lines += ['', f"Step identification: {idf['records']} records (1 s at 1 kHz, 0.2 N "
                  f"noise) fitted in {idf['fits_s']:.2f} s on {idf['workers']} cores; the whole "
                  f"extraction of that bag {idf['extract_s']:.2f} s. A bag the size of the "
                  f"{'quick' if r['quick'] else 'full'} campaign ({idf['campaign_points']} "
                  f"points and those records; points settled on the quasi-static bench) is "
                  f"extracted completely, figures included, in "
                  f"{idf['campaign_extract_s']:.1f} s."]
    if 'work_precision' in r:
        lines += bench_sections.render(r, root or pathlib.Path('.'))
    return '\n'.join(lines) + '\n'
