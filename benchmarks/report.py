"""BENCHMARKS.md from the measured data (bench.json): the key results, then every study's
sections, in the order of ``benchmarks.studies.STUDIES``.

The report opens with the key results (each figure, its goal, the measured value and the
commit it was measured at), then one section per bench.json key a study fills: its title and
method from ``methods.yaml`` (prose, no figures) and its table from the data. The report is the
current state: the hand-written long runs and dated notes (``docs/long_runs.md``) are listed by
title at the end, not copied. ``python -m benchmarks --render`` renders again from an existing
``results/bench.json``.
"""

from __future__ import annotations

import pathlib
from typing import Any

from benchmarks.studies import STUDIES
from benchmarks.tables import LONG_RUNS, RESULTS, Row, commit_of, methods, table

__all__ = ['key_results', 'render', 'long_run_titles', 'LONG_RUNS', 'RESULTS']


def key_results(r: dict[str, Any]) -> list[Row]:
    """(figure, goal, measured, commit) of every headline figure the data holds."""
    return [row for study in STUDIES for row in study.results(r)]


def render(r: dict[str, Any], root: pathlib.Path) -> str:
    """BENCHMARKS.md from a report (plots are written into ``root``)."""
    m = r['machine']
    lines = ['# pam_bench benchmarks', '',
             f"Measured in one run of `python -m benchmarks{' --quick' if r['quick'] else ''}` on "
             f"{m['platform']}, {m['cpus']} CPUs, Python {m['python']}, last run {r['date']} "
             f"at commit `{r['commit']}`; a study rerun alone (`python -m benchmarks --only`) "
             'keeps its own commit, named in its section and in the key results. Raw figures: '
             f'`{RESULTS}/bench.json`. Each section says how its figures are measured; code '
             'cites these sections by title instead of quoting figures. Runs too long for '
             f'every bench and dated notes are in `{LONG_RUNS}` (titles at the end).',
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
    titles = long_run_titles(root)
    if titles:
        lines += ['', '## Long runs and dated notes', '',
                  f'In `{LONG_RUNS}`, newest last; code cites them there by title:', '']
        lines += [f'- {t}' for t in titles]
    return '\n'.join(lines) + '\n'


def long_run_titles(root: pathlib.Path) -> list[str]:
    """The section titles of ``docs/long_runs.md`` (## and ###), in order."""
    path = root / LONG_RUNS
    if not path.exists():
        return []
    return [line.lstrip('#').strip() for line in path.read_text(encoding='utf-8').splitlines()
            if line.startswith(('## ', '### '))]
