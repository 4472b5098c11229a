"""`make bench`: one run on this machine -> BENCHMARKS.md and bench.json.

The studies are ``benchmarks.studies.STUDIES``: each measures into its keys of bench.json and
renders its sections (``benchmarks.report``). ``only`` reruns some and keeps every other
figure with the commit it was measured at.
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

from benchmarks.errors import UsageError
from benchmarks.report import render
from benchmarks.studies import STUDIES
from benchmarks.tables import REPOSITORY, RESULTS
from pam_bench.vocabulary.params import hint

__all__ = ['run_benchmarks', 'render_report']


def _commit() -> str:
    try:
        return subprocess.run(['git', 'rev-parse', '--short', 'HEAD'], capture_output=True,
                              text=True, check=True, cwd=REPOSITORY).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return 'unknown'


def run_benchmarks(quick: bool, root: pathlib.Path, scenes: list[str] | None = None,
                   only: list[str] | None = None) -> dict[str, Any]:
    """Run the benchmarks and write BENCHMARKS.md and bench.json into ``root``.

    With ``only`` just those studies run; their figures replace the same keys of an existing
    bench.json and every key records the commit and date it was measured at (``measured``).

    Raises:
        UsageError: an unknown study in ``only`` (named, with the nearest).
    """
    keys = [s.key for s in STUDIES]
    unknown = sorted(set(only or ()) - set(keys))
    if unknown:
        raise UsageError(f'unknown study {unknown[0]!r} ({hint(unknown[0], keys)})')
    now = datetime.datetime.now(datetime.UTC).isoformat(timespec='seconds')
    head = {'machine': {'platform': platform.platform(), 'cpus': os.cpu_count(),
                        'python': platform.python_version()},
            'date': now, 'commit': _commit(), 'quick': quick}
    path = root / RESULTS / 'bench.json'
    path.parent.mkdir(parents=True, exist_ok=True)
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
        for s in STUDIES:
            if only and s.key not in only:
                continue
            if quick and not s.quick and not only:
                print(f'{s.key}: left to the full run', flush=True)
                continue
            print(f'{s.key} ...', flush=True)
            t0 = time.perf_counter()
            where = out / s.key             # a folder per study: bag names do not meet
            where.mkdir()
            try:
                report.update(s.measure(quick, where, scenes))
            except Exception as exc:  # noqa: BLE001 - one study's failure ends only that study
                line = f'{type(exc).__name__}: {exc}'.splitlines()[0]
                print(f'{s.key}: failed: {line}', flush=True)
                report.setdefault('failed', {})[s.key] = {'error': line, 'commit': head['commit'],
                                                          'date': now}
                continue
            report.get('failed', {}).pop(s.key, None)
            took = time.perf_counter() - t0
            print(f'{s.key}: {took:.1f} s', flush=True)
            for key in s.fills:
                report['measured'][key] = {'commit': head['commit'], 'date': now,
                                           'quick': quick, 'study_wall_s': round(took, 1)}
    path.write_text(json.dumps(report, indent=2) + '\n', encoding='utf-8')
    render_report(root)
    return report


def render_report(root: pathlib.Path) -> pathlib.Path:
    """Write BENCHMARKS.md from ``root``/results/bench.json (and the titles of
    docs/long_runs.md); return its path.

    Raises:
        FileNotFoundError: no results/bench.json in ``root``.
    """
    report = json.loads((root / RESULTS / 'bench.json').read_text(encoding='utf-8'))
    md = root / 'BENCHMARKS.md'
    md.write_text(render(report, root), encoding='utf-8')
    return md
