"""`pam-bench extract`: bags -> CSV families, summary.json and a Markdown report.

The output folder is written completely or not at all: everything goes to a temporary folder
beside it that replaces DIR only when the extraction succeeded.
"""

from __future__ import annotations

import csv
import json
import pathlib
import time
from typing import Any

import numpy as np
import yaml

from pam_bench.analysis import plots
from pam_bench.analysis.errors import ExtractError
from pam_bench.analysis.force_models import FORCE_MODELS, fit_force_models
from pam_bench.analysis.identify import fit_step
from pam_bench.analysis.inverse_export import inverse_model_dict
from pam_bench.analysis.law_scores import score
from pam_bench.analysis.report import report_markdown
from pam_bench.analysis.smoothing import centred_polyfit
from pam_bench.analysis.static import gain_summary, kind_of
from pam_bench.analysis.summary import StepSummary, Summary
from pam_bench.bags.baginfo import bag_info
from pam_bench.bags.bagread import BagData, Points, StepRecord, read_bags
from pam_bench.vocabulary.outputs import check_output, staged_output

__all__ = ['extract', 'step_summary', 'coefficient_polynomials', 'inverse_model_of', 'VERB',
           'Summary', 'StepSummary']


VERB = 'pam-bench extract'
"""Who writes an extraction folder (its output marker)."""




def _fit_one(r: StepRecord) -> dict[str, Any]:
    dv = r.voltage_final_v - r.voltage_initial_v
    fit = fit_step(r.force_n, r.sample_period_s, dv)
    return {'x_mm': r.contraction_m * 1e3, 'direction': 'up' if r.direction == 0 else 'down',
            'u0_V': r.voltage_initial_v, 'u1_V': r.voltage_final_v,
            'b': fit.b, 'c': fit.c, 'd': fit.d, 'F_a0_N': fit.f_a0_n,
            'rms_error_N': fit.rms_error_n, 'delay_samples': fit.delay_samples}


def _fit_chunk(records: list[StepRecord]) -> list[dict[str, Any]]:
    return [_fit_one(r) for r in records]


def _fit_records(records: list[StepRecord], client: Any = None) -> list[dict[str, Any]]:
    """Fit every record; many records are shared out over the execution layer's workers in
    chunks (``cluster.layer``; order kept), a few are fitted here."""
    if len(records) < 40:
        return [_fit_one(r) for r in records]
    from pam_bench.cluster.layer import run_jobs
    n = max(1, len(records) // 16)
    chunks = [records[i:i + n] for i in range(0, len(records), n)]
    out: list[dict[str, Any]] = []
    for r in run_jobs(_fit_chunk, chunks, client, label='step fits', quiet=True):
        if not r.ok:
            raise ExtractError(f'step fits failed: {r.error}')
        out += r.value
    return out


def step_summary(records: list[StepRecord], client: Any = None) -> StepSummary:
    """Fits of every step response and their polynomials over x (``coefficient_polynomials``);
    ``client``: the cluster the fits run on (default: a local one when there are many)."""
    fits = _fit_records(records, client)
    return {'fits': fits, 'polynomials': coefficient_polynomials(fits)}


def coefficient_polynomials(fits: list[dict[str, Any]]) -> dict[str, Any]:
    """Per coefficient (b, c, d, F_a0), a polynomial in the centred and scaled contraction
    z = (x - x_mid) / x_half (004: 5th degree; lower when there are fewer positions) over the
    largest up step at each position, with its residuals.

    Args:
        fits: dicts with x_mm, direction, u1_V, b, c, d, F_a0_N.
    """
    by_x: dict[float, dict[str, Any]] = {}
    for f in fits:
        if f['direction'] == 'up':
            cur = by_x.get(f['x_mm'])
            if cur is None or f['u1_V'] > cur['u1_V']:
                by_x[f['x_mm']] = f
    xs = np.array(sorted(by_x))
    polys: dict[str, Any] = {}
    if len(xs) >= 2:
        for key in ('b', 'c', 'd', 'F_a0_N'):
            p = centred_polyfit(xs, np.array([by_x[x][key] for x in xs]))
            polys[key.replace('_N', '')] = {
                'coefficients_low_to_high': p.coefficients.tolist(), 'degree': p.degree,
                'x_mid_mm': p.x_mid, 'x_half_range_mm': p.x_half, 'x_mm': xs.tolist(),
                'residuals': p.residuals.tolist(), 'rms_residual': p.rms_residual}
    return polys


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


def _largest(points: dict[str, Points], kind: str) -> Points | None:
    """The largest protocol of a kind (full and quick grids may both be present)."""
    found = [p for p in points.values() if kind_of(p) == kind]
    return max(found, key=len) if found else None


def inverse_model_of(data: BagData, step: StepSummary | None) -> dict[str, Any] | None:
    """The inverse_model.yaml mapping of ``data`` with its step summary ``step``
    (``inverse_export.inverse_model_dict`` over its largest isometric protocol), or None."""
    return inverse_model_dict(step, _largest(data.points, 'isometric'))


MIN_SERIES_FOR_LAWS = 2
"""The force laws are fitted to at least this many series (one held x or F, as the README
demo's ramp, cannot identify how a law depends on the length)."""
ISOTONIC_MIN_X_M = 1e-4
"""An isotonic reading joins the force-law fit once the muscle has contracted this far (m),
and no reading stretched by more than this does: there the load hangs on the braid's
lock-up, which none of the laws describes."""


def nominal_length(runs: list[dict[str, Any] | None]) -> float:
    """The muscle's free length (m) from the first bag's run description: ``muscle.kind``
    picks ``muscle.nominal_length_m`` or ``straight_fibre.free_length_m``; 0.35 m (004) for a
    bag without one (a real bench's recorder)."""
    for run in runs:
        params = ((run or {}).get('parameters') or {}).get('muscle_1', {})
        params = params.get('ros__parameters', {})
        muscle = params.get('muscle', {})
        if muscle.get('kind') == 'straight_fibre':
            return float(params.get('straight_fibre', {}).get('free_length_m', 0.25))
        if 'nominal_length_m' in muscle:
            return float(muscle['nominal_length_m'])
    return 0.35


def model_comparison(points: dict[str, Points], direction: int | None = None,
                     nominal_length_m: float = 0.35, scored: bool = True
                     ) -> list[dict[str, Any]]:
    """Static force laws fitted to the isometric, isobaric and isotonic readings pooled; with
    ``direction`` (0 up, 1 down) to that branch of every sweep only. Each fit is then scored
    as a length law on the isotonic readings and as a stiffness law on the isobaric slopes
    (``analysis.law_scores``; ``scored=False`` leaves that out)."""
    kinds = ('isometric', 'isobaric', 'isotonic')
    use = [p for p in (_largest(points, k) for k in kinds) if p]
    if sum(len(np.unique(q.series_value)) for q in use) < MIN_SERIES_FOR_LAWS:
        return []               # one series cannot tell the laws' length dependence apart
    keep = [np.ones(len(q.t_s), bool) if direction is None else q.direction == direction
            for q in use]
    for q, k in zip(use, keep, strict=True):     # a load hanging on the locked braid: no law
        k &= q.contraction_m > (ISOTONIC_MIN_X_M if kind_of(q) == 'isotonic'
                                else -ISOTONIC_MIN_X_M)
    p, x, f = (np.concatenate([getattr(q, c)[k] for q, k in zip(use, keep, strict=True)])
               for c in ('pressure_pa', 'contraction_m', 'force_n'))
    fits = fit_force_models(p, x, f, nominal_length_m)
    iso, bar = _largest(points, 'isotonic'), _largest(points, 'isobaric')
    laws = {m.name: m for m in FORCE_MODELS}
    if scored:
        for fit in fits:
            score(fit, laws[fit['model']], iso, bar, nominal_length_m)
    return fits


def _branch_comparison(points: dict[str, Points], nominal_length_m: float
                       ) -> list[dict[str, Any]]:
    """The models fitted to the loading (up) and the unloading (down) branches apart, as 002
    does (its Fig. 11): hysteresis makes one curve through both a compromise."""
    up = model_comparison(points, 0, nominal_length_m, scored=False)
    down = model_comparison(points, 1, nominal_length_m, scored=False)
    out = []
    for a in up:
        b = next((m for m in down if m['model'] == a['model']), None)
        if b is not None:
            out.append({'model': a['model'], 'seed': a['seed'], 'n_params': a['n_params'],
                        'loading_rmse_N': a['rmse_N'], 'unloading_rmse_N': b['rmse_N'],
                        'loading_params': a['params'], 'unloading_params': b['params'],
                        'loading_stderr': a['stderr'], 'unloading_stderr': b['stderr']})
    return out


def _figures(tmp: pathlib.Path, data: BagData, summary: Summary,
             models: list[dict[str, Any]]) -> list[str]:
    names = []
    for kind in ('isobaric', 'isotonic', 'isometric'):
        p = _largest(data.points, kind)
        if p is not None and len(p) >= 2:
            names.append(plots.plot_family(p, kind, tmp))
            names.append(plots.plot_surfaces(p, kind, tmp))
            if kind == 'isometric' and 'isometric' in summary:
                names.append(plots.plot_gains(p, tmp))
    if summary.get('step_response', {}).get('polynomials'):
        names.append(plots.plot_step_polynomials(summary['step_response'], tmp))
    if models:
        names.append(plots.plot_model_residuals(models, tmp))
    return names


def _run_of(bag: str) -> dict[str, Any] | None:
    info = bag_info(bag)
    return None if info['run'] is None else {**info['run'], 'end': info['end']}


def extract(bags: list[str], out_dir: str, figures: bool = True, overwrite: bool = False
            ) -> Summary:
    """Read the bags; write DIR/summary.json, DIR/report.md, DIR/inverse_model.yaml (when the
    bags hold step responses and isometric points), DIR/<protocol>.csv and the figures. DIR
    is new, or an extraction's own with ``overwrite``; it takes its place only once complete
    (``vocabulary.outputs``).

    Raises:
        OutputError: DIR may not be written (checked before the bags are read).
        BagError: unreadable bags or no protocol points.
        ExtractError: points present but too few to extract anything.
    """
    check_output(out_dir, VERB, overwrite, bags)
    t0 = time.perf_counter()
    data = read_bags(bags)
    summary = Summary(**gain_summary(data.points))
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
    runs = [_run_of(b) for b in bags]      # how each bag was made (or None)
    l0 = nominal_length(runs)
    models = model_comparison(data.points, nominal_length_m=l0)
    if models:
        summary['model_comparison'] = [{k: v for k, v in m.items() if not k.startswith('_')}
                                       for m in models]
        summary['model_comparison_by_branch'] = _branch_comparison(data.points, l0)
        summary['model_comparison_length_m'] = l0
    inverse = inverse_model_of(data, summary.get('step_response'))
    t3 = time.perf_counter()
    summary['timing_s'] = {'read_and_static': t1 - t0, 'identification': t2 - t1,
                           'model_comparison': t3 - t2, 'records': len(data.records)}
    summary['bags'] = [str(b) for b in bags]
    summary['runs'] = runs
    with staged_output(out_dir, VERB, overwrite, bags) as tmp:
        _write_csv(tmp, data)
        if inverse is not None:
            summary['inverse_model'] = 'inverse_model.yaml'
            (tmp / 'inverse_model.yaml').write_text(
                yaml.safe_dump(inverse, sort_keys=False), encoding='utf-8')
        names = _figures(tmp, data, summary, models) if figures else []
        summary['timing_s']['figures'] = time.perf_counter() - t3
        summary['figures'] = names
        (tmp / 'summary.json').write_text(json.dumps(summary, indent=2) + '\n',
                                          encoding='utf-8')
        (tmp / 'report.md').write_text(report_markdown(summary), encoding='utf-8')
    return summary
