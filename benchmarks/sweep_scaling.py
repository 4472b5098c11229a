"""Sweeps on 1 and 2 workers, an external scheduler, and a projection to 10 000 jobs.

``config/sweeps/scaling.yaml`` (40 twin ``campaign_quick`` jobs) runs on a local cluster of
1 worker, then of 2, then on an external ``dask scheduler`` with two ``dask worker``
processes on 127.0.0.1; the three ``results.csv`` must be equal but for the ``seconds``
column. Each is timed with its workers warm (the twin imported and the compiled core loaded
on every worker first, as a cluster that has run one job is); the local ones also cold, the
cluster started by the sweep itself, which with jobs of a few tenths of a second is what a
short sweep on a fresh cluster mostly pays. The scheduler's own cost per task is measured
with 2000 empty tasks on the 2-worker cluster, and the bytes a job returns with pickle. The
projection of a sweep of N jobs on W workers: T = N c / W + N o, with c the mean job time
and o the scheduler's cost per task; the scheduler, not the workers, is the limit once
c / W < o, i.e. from W* = c / o workers.
"""

from __future__ import annotations

import csv
import dataclasses
import pathlib
import pickle
import time
from typing import Any

from benchmarks.study import Study
from benchmarks.tables import Row, commit_of, table

__all__ = ['STUDY', 'measure_scaling', 'scaling_section', 'scaling_results', 'project']

JOBS_PROJECTED = 10_000
WORKERS_PROJECTED = (1, 8, 64)


def _rows(path: pathlib.Path) -> list[dict[str, str]]:
    with open(path, newline='', encoding='utf-8') as fh:
        return [{k: v for k, v in r.items() if k != 'seconds'} for r in csv.DictReader(fh)]


def _external(sweep: Any, out: pathlib.Path) -> float:
    """Run ``sweep`` on an external scheduler with two workers on 127.0.0.1; wall s."""
    from distributed import Client

    from pam_bench.cluster.loopback import loopback_cluster
    logs = out / 'external_logs'
    logs.mkdir(parents=True, exist_ok=True)
    with loopback_cluster(logs, workers=2) as (address, _), \
            Client(address, timeout='30s') as client:
        return _timed_sweep(sweep, out / 'external', client)


def _noop(x: int) -> int:
    return x


def _warm() -> float:
    """On a worker: import the twin and load the compiled core (s), as the first job would."""
    import pam_bench.twin.protocol_run  # noqa: F401
    from pam_bench.models import jit
    return jit.warm_up()


def _timed_sweep(sweep: Any, out: pathlib.Path, client: Any) -> float:
    """Warm every worker of ``client``, then run ``sweep`` on its scheduler; wall s of the
    sweep alone."""
    from pam_bench.sweep.results import run_sweep
    client.run(_warm)
    t0 = time.perf_counter()
    run_sweep(sweep, out, {'scheduler': client.scheduler.address})
    return time.perf_counter() - t0


def _overhead_per_task(n: int = 2000) -> float:
    """Scheduler cost per task (s): ``n`` empty tasks on a 2-worker local cluster."""
    from distributed import wait

    from pam_bench.cluster.layer import connect
    with connect(workers=2) as client:
        wait(client.map(_noop, range(50), pure=False))        # warm
        t0 = time.perf_counter()
        wait(client.map(_noop, range(n), pure=False))
        return (time.perf_counter() - t0) / n


def project(n_jobs: int, workers: int, job_s: float, overhead_s: float) -> float:
    """Wall time (s) of ``n_jobs`` of ``job_s`` each on ``workers``, the scheduler paying
    ``overhead_s`` per task (module docstring)."""
    return n_jobs * job_s / workers + n_jobs * overhead_s


def measure_scaling(out: pathlib.Path, quick: bool = False) -> dict[str, Any]:
    """The study (module docstring); ``quick``: 6 jobs instead of 40, 500 empty tasks instead
    of 2000, no external scheduler (`make test` runs sweeps on one, ``test_real_cluster``)."""
    from pam_bench.cluster.layer import connect
    from pam_bench.config.paths import config_dir
    from pam_bench.sweep.jobs import run_job
    from pam_bench.sweep.results import RESULTS, run_sweep
    from pam_bench.sweep.spec import load_sweep
    sweep = load_sweep(config_dir() / 'sweeps' / 'scaling.yaml')
    if quick:
        sweep = dataclasses.replace(sweep, seeds=sweep.seeds[:6])
    out.mkdir(parents=True, exist_ok=True)
    wall: dict[str, float] = {}
    cold: dict[str, float] = {}
    for w in (1, 2):
        print(f'  sweep of {len(sweep.jobs())} jobs on {w} local worker(s) ...', flush=True)
        t0 = time.perf_counter()
        run_sweep(sweep, out / f'cold_{w}', {'workers': w})
        cold[f'local_{w}'] = time.perf_counter() - t0
        with connect(workers=w) as client:
            wall[f'local_{w}'] = _timed_sweep(sweep, out / f'local_{w}', client)
    rows = [dict(r) for r in csv.DictReader(open(out / 'local_1' / RESULTS, newline='',
                                                 encoding='utf-8'))]
    folders = ['local_1', 'local_2']
    if not quick:
        print('  the same on an external scheduler with 2 workers ...', flush=True)
        wall['external_2'] = _external(sweep, out)
        folders.append('external')
    same = all(_rows(out / f / RESULTS) == _rows(out / 'local_1' / RESULTS) for f in folders)
    job_s = sum(float(r['seconds']) for r in rows) / len(rows)
    job = sweep.jobs()[0]
    returned = len(pickle.dumps(run_job((job, sweep.engine, sweep.figures, sweep.duration_s))))
    print('  scheduler overhead per task ...', flush=True)
    tasks = 500 if quick else 2000
    overhead = _overhead_per_task(tasks)
    return {'jobs': len(rows), 'wall_s': wall, 'speedup_2': wall['local_1'] / wall['local_2'],
            'cold_wall_s': cold, 'cold_speedup_2': cold['local_1'] / cold['local_2'],
            'identical': bool(same), 'failed': sum(r['status'] != 'ok' for r in rows),
            'job_s': job_s, 'returned_bytes': returned, 'overhead_s': overhead,
            'overhead_tasks': tasks,
            'scheduler_limit_workers': job_s / overhead if overhead > 0 else float('inf'),
            'projection': {str(w): project(JOBS_PROJECTED, w, job_s, overhead)
                           for w in WORKERS_PROJECTED}}


def scaling_section(r: dict[str, Any], plots: pathlib.Path) -> list[str]:
    """The tables of the section."""
    s = r['sweep_scaling']
    lines = [f"{s['jobs']} twin `campaign_quick` jobs (`config/sweeps/scaling.yaml`), "
             f"{s['failed']} failed; results.csv equal on every cluster (but `seconds`): "
             f"{'yes' if s['identical'] else 'NO'}.", '']
    cold = s.get('cold_wall_s', {})
    lines += table(['cluster', 'sweep wall s, warm workers', 'jobs/s',
                    'wall s with the cluster started for it'],
                   [(k.replace('_', ', ') + ' worker(s)', f'{v:.1f}', f"{s['jobs'] / v:.2f}",
                     f'{cold[k]:.1f}' if k in cold else '-')
                    for k, v in s['wall_s'].items()])
    lines += ['', f"2 workers against 1: {s['speedup_2']:.2f}x with warm workers"
              + (f", {s['cold_speedup_2']:.2f}x counting the cluster's start-up and each "
                 "worker's first import and compiled-core load" if 'cold_speedup_2' in s
                 else '') + f". Mean job {s['job_s']:.3f} s, "
              f"{s['returned_bytes']} bytes returned per job, scheduler cost "
              f"{s['overhead_s'] * 1e3:.2f} ms per task ({s.get('overhead_tasks', 2000)} empty "
              'tasks).', '',
              f'Projection for {JOBS_PROJECTED} such jobs, T = N c / W + N o:', '']
    lines += table(['workers', 'projected wall', 'limited by'],
                   [(w, f'{t / 60:.1f} min', 'scheduler' if int(w) >
                     s['scheduler_limit_workers'] else 'workers')
                    for w, t in s['projection'].items()])
    lines += ['', f"The scheduler becomes the limit past about {s['scheduler_limit_workers']:.0f}"
              ' workers for jobs this short; longer jobs (the ROS engine, calibration) move that '
              'point up in proportion.']
    return lines


def scaling_results(r: dict[str, Any], commit: str) -> list[Row]:
    """Key-result rows."""
    s = r.get('sweep_scaling')
    if not s:
        return []
    cold = f", {s['cold_speedup_2']:.2f}x with start-up" if 'cold_speedup_2' in s else ''
    return [(f"sweep of {s['jobs']} twin jobs: 2 workers against 1", '>= 1.8x',
             f"{s['speedup_2']:.2f}x warm{cold} (results identical: "
             f"{'yes' if s['identical'] else 'no'})", commit)]


STUDY = Study('sweep_scaling', 'a 40-job sweep on 1 and 2 workers and an external scheduler; '
              'projection to 10 000 jobs',
              lambda quick, out, scenes: {'sweep_scaling': measure_scaling(out / 'scaling',
                                                                         quick)},
              (('sweep_scaling', scaling_section),),
              lambda r: scaling_results(r, commit_of(r, 'sweep_scaling')))
"""The execution layer's scaling (bench.json ``sweep_scaling``)."""
