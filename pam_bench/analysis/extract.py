"""`pam-bench extract`: bags -> CSV families, summary.json and a Markdown report.

The output folder is written completely or not at all: everything goes to a temporary folder
beside it that replaces DIR only when the extraction succeeded.
"""

from __future__ import annotations

import csv
import json
import pathlib
import shutil
import tempfile
import time
from typing import Any

import numpy as np

from pam_bench.analysis.bagread import BagData, StepRecord, read_bags
from pam_bench.analysis.identify import fit_step
from pam_bench.analysis.static import gain_summary

__all__ = ['extract', 'step_summary', 'ExtractError']


class ExtractError(Exception):
    """Nothing could be extracted (too few points to fit, ...)."""


def _fit_records(records: list[StepRecord]) -> list[dict[str, Any]]:
    fits = []
    for r in records:
        dv = r.voltage_final_v - r.voltage_initial_v
        fit = fit_step(r.force_n, r.sample_period_s, dv)
        fits.append({'x_mm': r.contraction_m * 1e3,
                     'direction': 'up' if r.direction == 0 else 'down',
                     'u0_V': r.voltage_initial_v, 'u1_V': r.voltage_final_v,
                     'b': fit.b, 'c': fit.c, 'd': fit.d, 'F_a0_N': fit.f_a0_n,
                     'rms_error_N': fit.rms_error_n, 'delay_samples': fit.delay_samples})
    return fits


def step_summary(records: list[StepRecord]) -> dict[str, Any]:
    """Fits of every step response and, per coefficient, a polynomial in the centred and
    scaled contraction z = (x - x_mid) / x_half (004: 5th degree) over the largest up step
    at each position, with its residuals."""
    fits = _fit_records(records)
    by_x: dict[float, dict[str, Any]] = {}
    for f in fits:
        if f['direction'] == 'up':
            cur = by_x.get(f['x_mm'])
            if cur is None or f['u1_V'] > cur['u1_V']:
                by_x[f['x_mm']] = f
    xs = np.array(sorted(by_x))
    polys: dict[str, Any] = {}
    if len(xs) >= 2:
        mid, half = float((xs.max() + xs.min()) / 2), float((xs.max() - xs.min()) / 2)
        z = (xs - mid) / half
        deg = min(5, len(xs) - 1)
        for key in ('b', 'c', 'd', 'F_a0_N'):
            y = np.array([by_x[x][key] for x in xs])
            coef = np.polynomial.polynomial.polyfit(z, y, deg)
            res = y - np.polynomial.polynomial.polyval(z, coef)
            polys[key.replace('_N', '')] = {
                'coefficients_low_to_high': coef.tolist(), 'degree': deg,
                'x_mid_mm': mid, 'x_half_range_mm': half,
                'residuals': res.tolist(), 'rms_residual': float(np.sqrt(np.mean(res ** 2)))}
    return {'fits': fits, 'polynomials': polys}


def _write_csv(path: pathlib.Path, data: BagData) -> None:
    for name, p in data.points.items():
        with open(path / f'{name}.csv', 'w', newline='', encoding='utf-8') as fh:
            w = csv.writer(fh)
            w.writerow(['series', 'series_value_SI', 'step', 'direction', 'set_value_SI',
                        'u_V', 'F_N', 'x_mm', 'p_MPa', 't_s'])
            for i in range(len(p)):
                w.writerow([p.series[i], p.series_value[i], p.step[i],
                            'up' if p.direction[i] == 0 else 'down', p.set_value[i],
                            p.voltage_v[i], p.force_n[i], p.contraction_m[i] * 1e3,
                            p.pressure_pa[i] * 1e-6, p.t_s[i]])


def extract(bags: list[str], out_dir: str) -> dict[str, Any]:
    """Read the bags, write DIR/summary.json, DIR/report.md and DIR/<protocol>.csv.

    Raises:
        BagError: unreadable bags or no protocol points.
        ExtractError: points present but too few to extract anything.
    """
    t0 = time.perf_counter()
    data = read_bags(bags)
    summary: dict[str, Any] = gain_summary(data.points)
    t1 = time.perf_counter()
    if data.records:
        try:
            summary['step_response'] = step_summary(data.records)
        except ValueError as exc:
            raise ExtractError(f'step responses too short to fit: {exc}') from None
    t2 = time.perf_counter()
    if not summary:
        raise ExtractError('too few points to extract anything (need at least two readings '
                           'where the muscle pulls in a series)')
    summary['timing_s'] = {'read_and_static': t1 - t0, 'identification': t2 - t1,
                           'records': len(data.records)}
    summary['bags'] = [str(b) for b in bags]
    out = pathlib.Path(out_dir)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = pathlib.Path(tempfile.mkdtemp(prefix=f'.{out.name}.', dir=out.parent))
    try:
        _write_csv(tmp, data)
        (tmp / 'summary.json').write_text(json.dumps(summary, indent=2) + '\n',
                                          encoding='utf-8')
        (tmp / 'report.md').write_text(_report(summary), encoding='utf-8')
        if out.exists():
            shutil.rmtree(out)
        tmp.rename(out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return summary


def _report(s: dict[str, Any]) -> str:
    lines = ['# Extracted characteristics', '']
    if 'isometric' in s:
        g = s['isometric']['gain_N_per_V']
        lines += [f"Isometric gain: max {g['max']:.1f} N/V at x = {g['x_mm_at_max']:.0f} mm, "
                  f"min {g['min']:.1f} N/V at x = {g['x_mm_at_min']:.0f} mm.", '']
    if 'isotonic' in s:
        g = s['isotonic']['gain_mm_per_V']
        lines += [f"Isotonic gain: max {g['max']:.2f} mm/V at u = {g['u_V_at_max']:.2f} V, "
                  f"F = {g['F_N_at_max']:.0f} N; min {g['min']:.2f} mm/V at "
                  f"u = {g['u_V_at_min']:.2f} V, F = {g['F_N_at_min']:.0f} N.", '']
    if 'isobaric' in s:
        lines += [f"Isobaric hysteresis: up to {s['isobaric']['hysteresis_mm_max']:.2f} mm.", '']
    if 'step_response' in s:
        lines += ['| x mm | direction | u0 -> u1 V | b 1/s | c 1/s^2 | d N/(V s^2) | F_a0 N | '
                  'RMS N |', '|---|---|---|---|---|---|---|---|']
        for f in s['step_response']['fits']:
            lines.append(f"| {f['x_mm']:.0f} | {f['direction']} | {f['u0_V']:.1f} -> "
                         f"{f['u1_V']:.1f} | {f['b']:.2f} | {f['c']:.1f} | {f['d']:.0f} | "
                         f"{f['F_a0_N']:.1f} | {f['rms_error_N']:.3f} |")
    return '\n'.join(lines) + '\n'



