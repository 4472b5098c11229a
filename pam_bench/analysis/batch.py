"""Many bags at once (``pam-bench extract BAG... --each``): each extracted on the execution
layer into its own folder, then one comparison across them.

The comparison has one row per bag, by recording date: the isometric and isotonic gains'
extremes, the step fits' b, c and d at every position all bags share (the largest up step at
that x), and every force law's parameters with their standard errors; then, per figure, its
drift over the recording dates (least-squares slope per day, with the first bag's value and
the relative change per 30 days). Written as ``comparison.csv``, ``comparison.md`` and
``drift.png``. A bag that cannot be read or extracted is a row with its one-line error; the
others complete.
"""

from __future__ import annotations

import csv
import datetime
import math
import pathlib
from typing import Any

import numpy as np

from pam_bench.analysis.errors import ExtractError
from pam_bench.analysis.extract import VERB
from pam_bench.analysis.summary import Summary
from pam_bench.vocabulary.outputs import staged_output

__all__ = ['extract_one', 'extract_each', 'comparison_rows', 'drift_rows']


def extract_one(job: tuple[str, str]) -> Summary:
    """One job: (bag folder, output folder) -> the bag's summary (``extract``)."""
    from pam_bench.analysis.extract import extract
    bag, out = job
    return extract([bag], out)


def _date(summary: Summary, bag: str) -> str:
    runs = summary.get('runs') or []
    if runs and runs[0] and runs[0].get('start'):
        return str(runs[0]['start'])
    from pam_bench.bags.bagread import open_bag
    reader = open_bag(pathlib.Path(bag))
    try:
        ns = reader.start_time
    finally:
        reader.close()
    return datetime.datetime.fromtimestamp(ns * 1e-9, datetime.UTC).isoformat()


def _step_at(summary: Summary) -> dict[float, dict[str, float]]:
    """X (mm) -> b, c, d of the largest up step there."""
    by: dict[float, dict[str, Any]] = {}
    for f in summary.get('step_response', {}).get('fits', []):
        if f['direction'] == 'up':
            cur = by.get(round(f['x_mm'], 3))
            if cur is None or f['u1_V'] > cur['u1_V']:
                by[round(f['x_mm'], 3)] = f
    return {x: {c: float(f[c]) for c in 'bcd'} for x, f in by.items()}


def comparison_rows(bags: list[str], summaries: list[Summary | None],
                    errors: list[str]) -> list[dict[str, Any]]:
    """One row per bag (module docstring), sorted by recording date; a failed bag keeps its
    error and no figures."""
    steps = [_step_at(s) if s else {} for s in summaries]
    common = sorted(set.intersection(*(set(s) for s in steps if s))) if any(steps) else []
    rows = []
    for bag, s, err, st in zip(bags, summaries, errors, steps, strict=True):
        row: dict[str, Any] = {'bag': pathlib.Path(bag).name, 'error': err}
        if s is None:
            rows.append(row)
            continue
        row['date'] = _date(s, bag)
        for kind, key, found in (('isometric', 'gain_N_per_V', s.get('isometric', {})),
                                 ('isotonic', 'gain_mm_per_V', s.get('isotonic', {}))):
            g = found.get(key, {})
            for ext in ('max', 'min'):
                if ext in g:
                    row[f'{kind}.{key}.{ext}'] = g[ext]
        for x in common:
            for c in 'bcd':
                row[f'step.{c}@{x:g}mm'] = st[x][c]
        for m in s.get('model_comparison', []):
            for name, value in m['params'].items():
                row[f"law.{m['model']}.{name}"] = value
                err_v = m.get('stderr', {}).get(name)
                if err_v is not None:
                    row[f"law.{m['model']}.{name}.stderr"] = err_v
        rows.append(row)
    return sorted(rows, key=lambda r: (r.get('date', '~'), r['bag']))


def drift_rows(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per figure (not the standard errors): its drift over the bags' dates."""
    ok = [r for r in rows if 'date' in r]
    if len(ok) < 2:
        return []
    t = np.array([datetime.datetime.fromisoformat(r['date']).timestamp() / 86400.0
                  for r in ok])
    keys = [k for k in ok[0] if k not in ('bag', 'error', 'date') and not k.endswith('.stderr')]
    out = []
    for k in keys:
        y = np.array([float(r.get(k, math.nan)) for r in ok])
        good = np.isfinite(y)
        if good.sum() < 2 or np.ptp(t[good]) <= 0.0:
            slope = 0.0 if good.sum() >= 2 else math.nan
        else:
            slope = float(np.polyfit(t[good] - t[good][0], y[good], 1)[0])
        first = float(y[good][0]) if good.any() else math.nan
        out.append({'figure': k, 'first': first, 'per_day': slope,
                    'rel_per_30_days': slope * 30.0 / first if first else math.nan})
    return out


def _write(rows: list[dict[str, Any]], drift: list[dict[str, Any]], out: pathlib.Path) -> None:
    keys: dict[str, None] = {}
    for r in rows:
        keys.update(dict.fromkeys(r))
    cols = list(keys)
    with open(out / 'comparison.csv', 'w', newline='', encoding='utf-8') as fh:
        w = csv.writer(fh)
        w.writerow(cols)
        for r in rows:
            w.writerow([r.get(c, '') for c in cols])
    show = [c for c in cols if c in ('bag', 'date', 'error') or c.startswith(
        ('isometric', 'isotonic', 'step.'))]
    lines = ['# Bags compared', '', '| ' + ' | '.join(show) + ' |', '|' + '---|' * len(show)]
    for r in rows:
        lines.append('| ' + ' | '.join(f'{r[c]:.5g}' if isinstance(r.get(c), float)
                                       else str(r.get(c, '')) for c in show) + ' |')
    if drift:
        lines += ['', '## Drift over the recording dates', '',
                  '| figure | first bag | per day | per 30 days, relative |', '|---|---|---|---|']
        lines += [f"| {d['figure']} | {d['first']:.5g} | {d['per_day']:.3g} | "
                  f"{d['rel_per_30_days'] * 100:+.2f} % |" for d in drift
                  if not d['figure'].startswith('law.')]
    (out / 'comparison.md').write_text('\n'.join(lines) + '\n', encoding='utf-8')
    _plot(rows, out)


def _plot(rows: list[dict[str, Any]], out: pathlib.Path) -> None:
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    ok = [r for r in rows if 'date' in r]
    if not ok:
        return
    from matplotlib.dates import date2num
    dates = date2num([datetime.datetime.fromisoformat(r['date']) for r in ok])
    keys = [k for k in ok[0] if k.startswith(('isometric', 'isotonic', 'step.'))]
    fig, ax = plt.subplots(figsize=(7, 4))
    for k in keys:
        y = np.array([float(r.get(k, math.nan)) for r in ok])
        if np.isfinite(y).any() and y[np.isfinite(y)][0]:
            ax.plot(dates, y / y[np.isfinite(y)][0], marker='o', label=k)
    ax.xaxis_date()
    ax.set_ylabel('relative to the first bag')
    ax.set_title('figures over the recording dates')
    ax.legend(fontsize=6)
    fig.autofmt_xdate()
    fig.tight_layout()
    fig.savefig(out / 'drift.png', dpi=100)
    plt.close(fig)


def extract_each(bags: list[str], out_dir: str, cluster: dict[str, Any] | None = None,
                 overwrite: bool = False) -> list[dict[str, Any]]:
    """Extract every bag into ``out_dir/<bag name>/`` on the execution layer, then write the
    comparison into ``out_dir`` (module docstring); the folder takes its place once complete
    (``vocabulary.outputs``). Returns the comparison's rows.

    Raises:
        OutputError: ``out_dir`` may not be written (checked before any job runs).
        ExtractError: two bags of the same folder name (their outputs would collide).
    """
    from pam_bench.cluster.layer import run_jobs
    names = [pathlib.Path(b).resolve().name for b in bags]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ExtractError(f'two bags are named {twice[0]!r}: their outputs would share '
                           f'{out_dir}/{twice[0]}; extract them apart')
    with staged_output(out_dir, VERB, overwrite, bags) as out:
        jobs = [(b, str(out / n)) for b, n in zip(bags, names, strict=True)]
        results = run_jobs(extract_one, jobs, label='extract', **(cluster or {}))
        summaries = [r.value if r.ok else None for r in results]
        errors = [r.error for r in results]
        rows = comparison_rows(bags, summaries, errors)
        _write(rows, drift_rows(rows), out)
    return rows
