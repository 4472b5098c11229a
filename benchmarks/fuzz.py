"""Fuzzing the inputs (issue 41): the hypothesis tests of ``test/cli/test_fuzz.py``, counted.

The study runs that test module (a checkout's; an installed package has no tests) with
hypothesis' statistics and records, per test, the cases that passed, failed and were invalid
(drawn, then discarded by a filter), and the module's wall time. The same tests run in `make
test`; this records how many cases they try, as the issue asks.
"""

from __future__ import annotations

import os
import pathlib
import re
import subprocess
import sys
import time
from typing import Any

from benchmarks.study import Study
from benchmarks.tables import REPOSITORY, Row, commit_of, table

__all__ = ['STUDY', 'parse_statistics', 'FUZZ_TESTS']

FUZZ_TESTS = pathlib.Path('test') / 'cli' / 'test_fuzz.py'
_TEST = re.compile(r'^\S*::(test_\w+):\s*$')
_COUNTS = re.compile(r'(\d+) passing, (\d+) failing, and (\d+) invalid')


def parse_statistics(text: str) -> list[dict[str, Any]]:
    """Rows (test, passing, failing, invalid) of pytest's ``--hypothesis-show-statistics``
    output (the generate phase of each test)."""
    rows: list[dict[str, Any]] = []
    test = None
    for line in text.splitlines():
        m = _TEST.match(line.strip())
        if m:
            test = m.group(1)
            continue
        c = _COUNTS.search(line)
        if c and test is not None:
            rows.append({'test': test, 'passing': int(c.group(1)), 'failing': int(c.group(2)),
                         'invalid': int(c.group(3))})
            test = None
    return rows


def measure(quick: bool, out: pathlib.Path, scenes: list[str] | None) -> dict[str, Any]:
    """Run the fuzz tests once and count their cases."""
    root = REPOSITORY
    if not (root / FUZZ_TESTS).exists():
        return {}
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, '-m', 'pytest', '-q', '-p', 'no:cacheprovider',
                           '-p', 'no:xdist', str(FUZZ_TESTS), '--hypothesis-show-statistics'],
                          cwd=root, env=env, capture_output=True, text=True, timeout=1800)
    wall = time.perf_counter() - t0
    return {'fuzz': {'rows': parse_statistics(proc.stdout), 'wall_s': wall,
                     'exit_code': proc.returncode}}


def section(r: dict[str, Any], root: pathlib.Path) -> list[str]:
    """One row per fuzz test."""
    f = r['fuzz']
    return table(['test', 'cases passed', 'failed', 'invalid (filtered)'],
                 [(x['test'], x['passing'], x['failing'], x['invalid']) for x in f['rows']]) + [
        '', f"The module took {f['wall_s']:.0f} s and exited {f['exit_code']}."]


def results(r: dict[str, Any]) -> list[Row]:
    """Cases tried, and whether every one ended cleanly."""
    f = r.get('fuzz')
    if not f or not f['rows']:
        return []
    passed = sum(x['passing'] for x in f['rows'])
    failed = sum(x['failing'] for x in f['rows'])
    return [('fuzzed inputs (scenes, YAML, sweeps, protocols, --set, bags): cases ending in '
             'exit 0 or one line', 'all', f'{passed} of {passed + failed}',
             commit_of(r, 'fuzz'))]


STUDY = Study('fuzz', 'fuzz tests of every input a user hands pam_bench, their cases counted',
              measure, (('fuzz', section),), results)
