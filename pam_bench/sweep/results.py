"""Running a sweep on the execution layer, its ``results.csv`` and its plots.

``results.csv`` has one row per job, in the sweep's job order: its id, scene, seed, the values
it sets, its figures, its status (``ok``, ``no figure: ...`` naming the figures the run did not
give, or the one-line error) and its wall time. It is written whole again as each job ends,
so an interrupted sweep keeps every job it finished; a rerun reads it and skips them. Apart
from the time column the file does not depend on how many workers ran it, or where. Plots:
each figure against the one varied setting (the seeds' mean and spread), or as a heat map over
two (the seeds' mean).
"""

from __future__ import annotations

import csv
import math
import pathlib
from typing import Any

import numpy as np

from pam_bench.sweep.jobs import run_job
from pam_bench.sweep.spec import Job, Sweep

__all__ = ['run_sweep', 'read_results', 'plot_results', 'RESULTS', 'NO_FIGURE']

RESULTS = 'results.csv'


def _columns(sweep: Sweep) -> list[str]:
    return ['job', 'scene', 'seed', *sweep.paths, *sweep.figures, 'status', 'seconds']


def _fmt(v: Any) -> str:
    if isinstance(v, float):
        return repr(v)
    return str(v)


NO_FIGURE = 'no figure: '
"""The status of a job that ran but did not give every figure (a run too short for it, a
protocol without it): the missing figures follow."""


def _status(ok: bool, error: str, figures: dict[str, float]) -> str:
    """``ok``, the job's one-line error, or ``NO_FIGURE`` and the figures that came out NaN."""
    if not ok:
        return error.replace('\n', ' ')
    missing = [f for f, v in figures.items() if not math.isfinite(v)]
    if missing:
        return (NO_FIGURE + ', '.join(missing) + ' (the run did not give them: too short, or '
                'its protocol or data lack them)')
    return 'ok'


def _finished(status: str) -> bool:
    """A job a rerun skips: done, or done without some figure (the same run gives the same)."""
    return status == 'ok' or status.startswith(NO_FIGURE)


def read_results(path: pathlib.Path) -> dict[str, dict[str, str]]:
    """Job id -> its row (strings) of an earlier ``results.csv`` (empty when there is none)."""
    if not path.exists():
        return {}
    with open(path, newline='', encoding='utf-8') as fh:
        return {row['job']: row for row in csv.DictReader(fh)}


def run_sweep(sweep: Sweep, out: pathlib.Path, cluster: dict[str, Any] | None = None
              ) -> list[dict[str, Any]]:
    """Run the jobs ``out/results.csv`` does not hold as done, writing the file whole again
    as each job ends (an interrupted sweep keeps every job it finished); return the rows
    (module docstring). A failed job is a row with its error; the others complete."""
    from pam_bench.cluster.layer import JobResult, run_jobs
    out.mkdir(parents=True, exist_ok=True)
    path = out / RESULTS
    cols = _columns(sweep)
    old = read_results(path)
    jobs = sweep.jobs()
    todo = [j for j in jobs if not _finished(old.get(j.id, {}).get('status', '')) or
            any(c not in old[j.id] for c in cols)]
    done: dict[str, dict[str, Any]] = {}

    def rows() -> list[dict[str, Any]]:
        """Every job that ran, now or before, in the sweep's order."""
        out_rows = []
        for j in jobs:
            row: dict[str, Any] = {'job': j.id, 'scene': j.scene, 'seed': j.seed,
                                   **dict(j.values)}
            if j.id in done:
                row.update(done[j.id])
            elif j.id in old and all(c in old[j.id] for c in cols):
                row.update({c: old[j.id][c] for c in (*sweep.figures, 'status', 'seconds')})
            else:
                continue                       # not run yet: no row
            out_rows.append(row)
        return out_rows

    def keep(r: JobResult) -> None:
        job: Job = r.item[0]
        figs = r.value if r.ok else {f: math.nan for f in sweep.figures}
        done[job.id] = {**figs, 'status': _status(r.ok, r.error, figs),
                        'seconds': round(r.seconds, 3)}
        _write(path, cols, rows())

    if todo:
        tasks = [(j, sweep.engine, sweep.figures, sweep.duration_s) for j in todo]
        run_jobs(run_job, tasks, label=f'sweep {sweep.name}', ros=sweep.engine == 'ros',
                 on_result=keep, **(cluster or {}))
    final = rows()
    _write(path, cols, final)
    return final


def _write(path: pathlib.Path, cols: list[str], rows: list[dict[str, Any]]) -> None:
    """``results.csv`` written whole, atomically (a file beside it, then renamed)."""
    tmp = path.with_suffix('.csv.part')
    try:
        with open(tmp, 'w', newline='', encoding='utf-8') as fh:
            w = csv.writer(fh)
            w.writerow(cols)
            for row in rows:
                w.writerow([_fmt(row.get(c, '')) for c in cols])
        tmp.replace(path)
    finally:
        tmp.unlink(missing_ok=True)


def _num(v: Any) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def plot_results(sweep: Sweep, rows: list[dict[str, Any]], out: pathlib.Path) -> list[str]:
    """One PNG per figure (module docstring); returns the file names."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    paths = sweep.paths
    names = []
    for fig_key in sweep.figures:
        fig, ax = plt.subplots(figsize=(6, 4))
        if len(paths) == 1:
            groups: dict[tuple[str, float], list[float]] = {}
            for r in rows:
                groups.setdefault((r['scene'], _num(r[paths[0]])), []).append(
                    _num(r[fig_key]))
            for scene in dict.fromkeys(r['scene'] for r in rows):
                px = sorted(x for s, x in groups if s == scene)
                py = [float(np.nanmean(groups[scene, x])) for x in px]
                pe = [float(np.nanstd(groups[scene, x])) for x in px]
                ax.errorbar(px, py, yerr=pe, marker='o', capsize=3, label=scene)
            ax.set_xlabel(paths[0])
            ax.legend(fontsize=7)
        elif len(paths) >= 2:
            xs = sorted({_num(r[paths[0]]) for r in rows})
            ys = sorted({_num(r[paths[1]]) for r in rows})
            grid = np.full((len(ys), len(xs)), np.nan)
            acc: dict[tuple[int, int], list[float]] = {}
            for r in rows:
                key = (ys.index(_num(r[paths[1]])), xs.index(_num(r[paths[0]])))
                acc.setdefault(key, []).append(_num(r[fig_key]))
            for (i, j), v in acc.items():
                grid[i, j] = np.nanmean(v) if np.isfinite(v).any() else np.nan
            mesh = ax.imshow(grid, origin='lower', aspect='auto',
                             extent=(-0.5, len(xs) - 0.5, -0.5, len(ys) - 0.5))
            ax.set_xticks(range(len(xs)), [f'{x:.4g}' for x in xs], fontsize=7)
            ax.set_yticks(range(len(ys)), [f'{y:.4g}' for y in ys], fontsize=7)
            ax.set_xlabel(paths[0])
            ax.set_ylabel(paths[1])
            fig.colorbar(mesh, ax=ax)
        else:
            vals = [_num(r[fig_key]) for r in rows]
            ax.plot([r['seed'] for r in rows], vals, 'o')
            ax.set_xlabel('seed')
        ax.set_title(fig_key, fontsize=9)
        name = f"{fig_key.replace('.', '_')}.png"
        fig.tight_layout()
        fig.savefig(out / name, dpi=100)
        plt.close(fig)
        names.append(name)
    return names
