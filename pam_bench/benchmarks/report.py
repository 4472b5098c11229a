"""BENCHMARKS.md from the measured data (bench.json): the key results, then every study's
sections, in the order of ``benchmarks.studies.STUDIES``.

The report opens with the key results (each figure, its goal, the measured value and the
commit it was measured at), then one section per bench.json key a study fills: its title and
method from ``methods.yaml`` (prose, no figures) and its table from the data. The hand-written
long runs (``docs/long_runs.md``, runs too long for every `pam-bench bench`) are included whole
at the end. ``pam-bench bench --render`` renders again from an existing bench.json.
"""

from __future__ import annotations

import pathlib
from typing import Any

from pam_bench.benchmarks.studies import STUDIES
from pam_bench.benchmarks.tables import LONG_RUNS, Row, commit_of, methods, table

__all__ = ['key_results', 'render', 'LONG_RUNS']


def key_results(r: dict[str, Any]) -> list[Row]:
    """(figure, goal, measured, commit) of every headline figure the data holds."""
    return [row for study in STUDIES for row in study.results(r)]


def render(r: dict[str, Any], root: pathlib.Path) -> str:
    """BENCHMARKS.md from a report (plots are written into ``root``)."""
    m = r['machine']
    lines = ['# pam_bench benchmarks', '',
             f"Measured in one run of `pam-bench bench{' --quick' if r['quick'] else ''}` on "
             f"{m['platform']}, {m['cpus']} CPUs, Python {m['python']}, last run {r['date']} "
             f"at commit `{r['commit']}`; a study rerun alone (`pam-bench bench --only`) "
             'keeps its own commit, named in its section and in the key results. Raw figures: '
             '`bench.json`. Each section says how its figures are measured; code cites these '
             'sections by title instead of quoting figures.',
             '', '## Key results', ''] + table(['figure', 'goal', 'measured', 'commit'],
                                               key_results(r))
    for study in STUDIES:
        for key, section in study.sections:
            if not r.get(key):
                continue
            text = methods()[key]
            lines += ['', f"## {text['title']}", '',
                      text['method'] + f' (Commit {commit_of(r, key)}.)', '']
            lines += section(r, root)
    long_runs = root / LONG_RUNS
    if long_runs.exists():
        lines += ['', long_runs.read_text(encoding='utf-8').strip()]
    return '\n'.join(lines) + '\n'
