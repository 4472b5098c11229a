"""Study ``scenes``: protocol scenes through the nodes (wall time, real-time factor), the
campaign's readings against its numpy twin (the scene's steps and 1 ms), and the extraction of
the bags against `pam-bench truth` with the identification's speed."""

from __future__ import annotations

import os
import pathlib
import time
from typing import Any

import numpy as np

from benchmarks.exchange_step import SCENE_STEPS
from benchmarks.runs import scene_bag, scene_run
from benchmarks.study import Study
from benchmarks.tables import Row, commit_of, pct, table
from pam_bench.verify.reference_check import run_against_twin
from pam_bench.vocabulary.run import Layout

__all__ = ['STUDY', 'measure']


def measure(quick: bool, out: pathlib.Path, scenes: list[str] | None) -> dict[str, Any]:
    """The scenes (default: the campaign), the campaign against its twin, the extraction."""
    campaign = 'campaign_quick' if quick else 'campaign'
    names = scenes or [campaign]
    report: dict[str, Any] = {'scenes': [scene_run(n, out, Layout.COMPOSED) for n in names]}
    if campaign in names:
        print(f'{campaign} against its numpy twin (scene steps, then 1 ms) ...', flush=True)
        bag = scene_bag(campaign, out, Layout.COMPOSED)
        report['campaign'] = {'scene': campaign,
                              'twin_same_steps': run_against_twin(bag, campaign, *SCENE_STEPS)}
        if not quick:         # 26 s for campaign_quick, 27 min for the campaign
            report['campaign']['twin_1ms'] = run_against_twin(bag, campaign, 0.001, 0.001)
    print('extraction against truth, identification speed ...', flush=True)
    report['extraction'] = _extraction(out, names, quick)
    return report


def _extraction(out: pathlib.Path, names: list[str], quick: bool) -> dict[str, Any]:
    """Extract each recorded scene bag, compare with its truth; time 680 step fits."""
    from pam_bench.analysis.extract import extract
    from pam_bench.bags.errors import BagError
    from pam_bench.twin.quasistatic import QuasiStaticBench
    from pam_bench.verify.truth import compare, scene_schedule, truth_summary
    rows = []
    for name in names:
        try:
            summary = extract([str(scene_bag(name, out, Layout.COMPOSED))], str(out / f'{name}_x'),
                              figures=False)
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
    from pam_bench.bags.bagwrite import write_bag
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


def _layout(s: dict[str, Any]) -> str:
    """The layout a scene row ran in (rows from before composed was the default lack it)."""
    return Layout.parse(str(s.get('layout', Layout.PROCESSES.value))).value


def scenes_section(r: dict[str, Any], root: pathlib.Path) -> list[str]:
    return table(['scene', 'layout', 'sim time', 'wall time (lock-step)', 'real-time factor',
                  'wall time with start-up', 'exchange steps', 'steps/s'],
                 [(s['scene'], _layout(s), f"{s['sim_s']:.0f} s ({s['sim_s'] / 3600:.2f} h)",
                   f"{s['wall_s_lockstep']:.1f} s", f"{s['real_time_factor']:.1f}x",
                   f"{s['wall_s_total']:.1f} s", s['exchange_steps'],
                   f"{s['lockstep_rate_steps_per_s']:.0f}") for s in r['scenes']])


def campaign_section(r: dict[str, Any], root: pathlib.Path) -> list[str]:
    cmp = r['campaign']
    rows: list[Row] = []
    for key, label in (('twin_same_steps', 'scene steps'), ('twin_1ms', '1 ms / 1 ms')):
        if key not in cmp:
            continue
        t = cmp[key]
        rows += [(label, row['protocol'], row['readings'],
                  f"{row['max_error']:.3f} {row['unit']}", f"{row['p99_error']:.3f}",
                  pct(row['max_error_pct_fs'])) for row in t['protocols']]
        rec = t['records']
        rows.append((label, 'step records b, c, d', rec['records'],
                     f"{100 * rec['max_bcd_rel_error']:.2f} %",
                     f"1 <-> 5 V: {100 * rec['max_bcd_rel_error_1_5V']:.2f} %", ''))
    t = cmp.get('twin_1ms')
    tail = ([f"The 1 ms twin took {t['twin_exchanges']} exchanges and {t['twin_wall_s']:.0f} s "
             'of wall time in one process.'] if t else
            ['The 1 ms twin is left out of a quick run.'])
    return [f"Scene `{cmp['scene']}`.", ''] + table(
        ['twin', 'protocol', 'readings', 'max difference', '99th percentile', '% FS'],
        rows) + [''] + tail


def extraction_section(r: dict[str, Any], root: pathlib.Path) -> list[str]:
    ex = r['extraction']
    rows: list[Row] = []
    for row in ex['scenes']:
        def pct(key: str, row: dict[str, Any] = row) -> str:
            return f'{100 * abs(row[key]):.2f} %' if key in row else '-'

        def bcd(prefix: str, row: dict[str, Any] = row) -> str:
            keys = [f'{prefix}_{c}_max_abs_rel_error' for c in 'bcd']
            return ', '.join(f'{100 * row[k]:.1f} %' for k in keys) if keys[0] in row else '-'
        for against, suffix, step in (('parameters', '', 'step_fits'),
                                      ('reference', '_reference', 'step_reference_fits')):
            rows.append((row['scene'], against,
                         pct(f'isometric_gain{suffix}_max_abs_rel_error'),
                         pct(f'isotonic_gain{suffix}_max_rel_error'),
                         pct(f'isobaric_hysteresis{suffix}_rel_error'), bcd(step)))
    idf = ex['identification']
    speed = table(['what', 'wall time'], [
        (f"{idf['records']} step fits (1 s at 1 kHz, noise on), {idf['workers']} cores",
         f"{idf['fits_s']:.2f} s"),
        ('whole extraction of that bag', f"{idf['extract_s']:.2f} s"),
        (f"a bag the size of the {'quick' if r['quick'] else 'full'} campaign "
         f"({idf['campaign_points']} points and those records), figures included",
         f"{idf['campaign_extract_s']:.1f} s")])
    return table(['scene', 'against', 'isometric gain', 'isotonic max gain',
                  'isobaric hysteresis', 'step b, c, d'], rows) + [''] + speed


def _campaign_max(r: dict[str, Any], unit: str) -> tuple[float, float | None] | None:
    """Largest reading difference of the campaign against its 1 ms twin in ``unit``."""
    cmp = r.get('campaign')
    if not cmp or 'twin_1ms' not in cmp:
        return None
    rows = [row for row in cmp['twin_1ms']['protocols'] if row['unit'] == unit]
    if not rows:
        return None
    worst = max(rows, key=lambda row: row['max_error'])
    return worst['max_error'], worst['max_error_pct_fs']


def results(r: dict[str, Any]) -> list[Row]:
    """The campaign through the nodes, its readings against the 1 ms reference, and the
    extraction's speed."""
    rows: list[Row] = []
    commit = commit_of(r, 'scenes')
    for s in r.get('scenes', []):
        if s['scene'] in ('campaign', 'campaign_quick'):
            composed = _layout(s) == Layout.COMPOSED.value
            goal = ('-' if s['scene'] != 'campaign' else
                    '<= 30 s (>= 730x real time)' if composed else '>= 36x real time')
            rows.append((f"`{s['scene']}` through the nodes, {_layout(s)}", goal,
                         f"{s['real_time_factor']:.1f}x ({s['wall_s_lockstep']:.0f} s for "
                         f"{s['sim_s'] / 3600:.2f} h)", commit))
    force, x = _campaign_max(r, 'N'), _campaign_max(r, 'mm')
    if force:
        rows.append(('campaign force readings against the 1 ms reference', '<= 0.2 % FS',
                     f'{force[0]:.3f} N ({pct(force[1])} % FS)', commit))
    if x:
        rows.append(('campaign contraction readings against the 1 ms reference',
                     '<= 0.2 % of the 210 mm belt travel (0.42 mm)', f'{x[0]:.3f} mm', commit))
    ex = r.get('extraction')
    if ex:
        commit = commit_of(r, 'extraction')
        idf = ex['identification']
        rows.append(('extraction of a campaign-sized bag, figures included', '< 30 s',
                     f"{idf['campaign_extract_s']:.1f} s", commit))
        rows.append((f"step fits ({idf['records']} records)", '< 10 s',
                     f"{idf['fits_s']:.2f} s on {idf['workers']} cores", commit))
    return rows


STUDY = Study('scenes', 'the campaign through the nodes, against its twin, and its extraction',
              measure, (('scenes', scenes_section), ('campaign', campaign_section),
                        ('extraction', extraction_section)), results)
"""Scenes, the campaign against its twin, extraction (bench.json ``scenes``, ``campaign``,
``extraction``)."""
