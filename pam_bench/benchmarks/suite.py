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
from pam_bench.bringup.runner import run_scene
from pam_bench.config.scene import load_scene
from pam_bench.verify.calibration import calibration_figures
from pam_bench.verify.reference_check import FULL_SCALE_N, run_against_twin, series_readings

__all__ = ['run_benchmarks', 'exchange_step_error']

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
        campaign = 'campaign_quick' if quick else 'campaign'
        names = scenes or [campaign]
        report['scenes'] = []
        for name in names:
            print(f'scene {name} ...', flush=True)
            report['scenes'].append(_scene_run(name, out))
        if campaign in names:
            print(f'{campaign} against its numpy twin (scene steps, then 1 ms) ...', flush=True)
            report['campaign'] = {'scene': campaign, 'twin_same_steps': run_against_twin(
                out / campaign, campaign, *SCENE_STEPS), 'twin_1ms': run_against_twin(
                out / campaign, campaign, 0.001, 0.001)}
        print('extraction against truth, identification speed ...', flush=True)
        report['extraction'] = _extraction(out, names, quick)
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
        f"| lock-step, demo scene (10 ms exchanges), {ls['participants']} participants in "
        f"separate processes | {ls['demo_lockstep_steps_per_s']:.0f} steps/s |",
        f"| ratio lock-step / ping-pong | {ls['ratio_lockstep_to_pingpong']:.3f} |", '',
        'Each exchange step costs every participant one /clock delivery, its inputs, its '
        'outputs and one acknowledgement, along a chain of same-exchange inputs (valve -> '
        'muscle -> loading servo -> encoder -> sequencer); with seven Python processes on two '
        'cores the executor overhead per message, not the physics, sets the rate. That is why '
        'the characterisation scenes exchange once per dwell, not once per millisecond: the '
        'devices pass each other whole sub-step trajectories instead.']
    lines += _scenes_section(r)
    lines += _exchange_section(r)
    lines += _extraction_section(r)
    if 'work_precision' in r:
        lines += bench_sections.render(r, root or pathlib.Path('.'))
    return '\n'.join(lines) + '\n'


def _scenes_section(r: dict[str, Any]) -> list[str]:
    lines = ['', '## Scenes through separate-process nodes', '',
             '| scene | sim time | wall time (lock-step) | real-time factor | wall time with '
             'start-up | exchange steps | steps/s |', '|---|---|---|---|---|---|---|']
    for s in r['scenes']:
        lines.append(f"| {s['scene']} | {s['sim_s']:.0f} s ({s['sim_s'] / 3600:.2f} h) | "
                     f"{s['wall_s_lockstep']:.1f} s | {s['real_time_factor']:.1f}x | "
                     f"{s['wall_s_total']:.1f} s | {s['exchange_steps']} | "
                     f"{s['lockstep_rate_steps_per_s']:.0f} |")
    cmp = r.get('campaign')
    if not cmp:
        return lines
    lines += ['', f"### {cmp['scene']}: every reading against its numpy twin", '',
              "The recorded run (3 s exchanges at most, 5 ms sub-steps, load-cell noise 0.2 N "
              'and 16-bit counts) against the numpy twin of the same scene '
              '(`twin.protocol_run`: the '
              "sequencer's own state machine on the numpy bench, noise-free sensors): first at "
              "the scene's own steps, where only the sensor noise differs, then at 1 ms "
              'exchanges on 1 ms sub-steps, the reference. Contraction readings come from the '
              'encoder, which the noise does not reach; force readings carry the load-cell '
              'noise. Step records: the largest relative change of the fitted b, c, d (004 '
              'Eq. 2), over all records and over the 1 <-> 5 V identification steps.', '',
              '| twin | protocol | readings | max difference | 99th percentile | % FS |',
              '|---|---|---|---|---|---|']
    for key, label in (('twin_same_steps', 'scene steps'), ('twin_1ms', '1 ms / 1 ms')):
        t = cmp[key]
        for row in t['protocols']:
            fs = '' if row['max_error_pct_fs'] is None else f"{row['max_error_pct_fs']:.3f}"
            lines.append(f"| {label} | {row['protocol']} | {row['readings']} | "
                         f"{row['max_error']:.3f} {row['unit']} | {row['p99_error']:.3f} | "
                         f'{fs} |')
        rec = t['records']
        lines.append(f"| {label} | step records b, c, d | {rec['records']} | "
                     f"{100 * rec['max_bcd_rel_error']:.2f} % | 1 <-> 5 V: "
                     f"{100 * rec['max_bcd_rel_error_1_5V']:.2f} % | |")
    t = cmp['twin_1ms']
    lines += ['', f"The 1 ms twin took {t['twin_exchanges']} exchanges and "
              f"{t['twin_wall_s']:.0f} s of wall time in one process."]
    return lines


def _exchange_section(r: dict[str, Any]) -> list[str]:
    lines = ['', '## Exchange step and sub-step against error', '',
             'One series of readings (0.1 V or 10 N steps, 3 s dwell) on the numpy twin, as the '
             'nodes run it, at the exchange step (the longest; the sequencer asks for 1 ms at '
             'every new set value, the valve for 0.1 s while its pressure is in transient, '
             'until it has seen the chamber volume standing still) and the sub-step of the '
             'coupled muscle and drive, '
             'against the same series at 1 ms exchanges on 1 ms sub-steps; force errors also '
             'in % of the 2 kN full scale. The exchange step changes only what an exchange '
             'holds: a new loading-servo set value (1 ms later) and the chamber volume the '
             'valve integrates with; the sub-step is the discretisation of the mechanics '
             '(backward Euler, first order). Isotonic at 50 N is the hard case: near the '
             'threshold pressure the light muscle contracts by tens of mm per 0.1 V.', '',
             '| protocol | held | exchange step | sub-step | exchanges per reading | max error '
             '| % FS | wall s (reference wall s) |', '|---|---|---|---|---|---|---|---|']
    for row in r['exchange_step']:
        fs = '' if row['max_error_pct_fs'] is None else f"{row['max_error_pct_fs']:.3f}"
        lines.append(f"| {row['protocol']} | {row['held']:g} | {row['exchange_step_s']:g} s | "
                     f"{1e3 * row['sub_step_s']:g} ms | {row['exchanges_per_reading']:.1f} | "
                     f"{row['max_error']:.3f} {row['unit']} | {fs} | {row['wall_s']:.2f} "
                     f"({row['wall_s_1ms']:.1f}) |")
    if r.get('record_exchange'):
        lines += ['', '## Step records', '',
                  'A 1 s record at 1 kHz after a valve step at a held position: the valve '
                  'reports every 1 ms sample of an exchange, the muscle and the drive are '
                  'solved on those samples and the load cell measures each, so the record '
                  'needs no 1 ms exchange. Each row: one step recorded with exchanges of H '
                  'against the same step at 1 ms exchanges (both on 1 ms sub-steps), b, c, d of '
                  '004 Eq. 2 fitted to both (numpy bench, noise on, same seed). What differs is '
                  'the chamber volume the valve holds over an exchange (the belt stretches by '
                  'F / k_b).', '',
                  '| x mm | step | H | exchanges per record | largest b, c, d change | largest '
                  'force difference | wall s (1 ms wall s) |', '|---|---|---|---|---|---|---|']
        for row in r['record_exchange']:
            lines.append(f"| {row['x_mm']:.0f} | {row['u0_V']:g} -> {row['u1_V']:g} V | "
                         f"{1e3 * row['record_exchange_s']:g} ms | {row['exchanges']} | "
                         f"{100 * row['max_abs_rel_error']:.3f} % | "
                         f"{row['max_force_difference_N']:.2f} N | {row['wall_s']:.2f} "
                         f"({row['wall_s_1ms']:.2f}) |")
    return lines


def _extraction_section(r: dict[str, Any]) -> list[str]:
    ex = r.get('extraction')
    if not ex:
        return []
    lines = ['', '## Extraction against `pam-bench truth`', '',
             "Each scene bag above extracted and compared with what the scene's parameters "
             'imply (relative errors, largest over the series or records), twice: with the '
             'parameter figures (friction-free backbone gains on the quasi-static bench; the '
             "valve loop's b, c and the settled gain for a step), and with the reference, the "
             'same scene run noise-free on the numpy twin through the same estimators. The '
             "first includes the estimators' bias on a bench with braid friction; the second "
             "is the measurement's own error (noise, quantisation, fit).", '',
             '| scene | against | isometric gain | isotonic max gain | isobaric hysteresis '
             '| step b, c, d |', '|---|---|---|---|---|---|']
    for row in ex['scenes']:
        def pct(key: str, row: dict = row) -> str:
            return f'{100 * abs(row[key]):.2f} %' if key in row else '-'

        def bcd(prefix: str, row: dict = row) -> str:
            keys = [f'{prefix}_{c}_max_abs_rel_error' for c in 'bcd']
            if keys[0] not in row:
                return '-'
            return ', '.join(f'{100 * row[k]:.1f} %' for k in keys)
        for against, suffix, step in (('parameters', '', 'step_fits'),
                                      ('reference', '_reference', 'step_reference_fits')):
            lines.append(f"| {row['scene']} | {against} | "
                         f"{pct(f'isometric_gain{suffix}_max_abs_rel_error')} | "
                         f"{pct(f'isotonic_gain{suffix}_max_rel_error')} | "
                         f"{pct(f'isobaric_hysteresis{suffix}_rel_error')} | {bcd(step)} |")
    idf = ex['identification']
    lines += ['', f"Step identification: {idf['records']} records (1 s at 1 kHz, 0.2 N "
              f"noise) fitted in {idf['fits_s']:.2f} s on {idf['workers']} cores; the whole "
              f"extraction of that bag {idf['extract_s']:.2f} s. A bag the size of the "
              f"{'quick' if r['quick'] else 'full'} campaign ({idf['campaign_points']} "
              f"points and those records; points settled on the quasi-static bench) is "
              f"extracted completely, figures included, in "
              f"{idf['campaign_extract_s']:.1f} s."]
    return lines
