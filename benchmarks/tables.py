"""What every study's report section is made of: Markdown tables, the method texts, commits."""

from __future__ import annotations

import functools
import pathlib
import statistics
from collections.abc import Iterable, Sequence
from typing import Any

import yaml

__all__ = ['Row', 'table', 'methods', 'commit_of', 'pct', 'spread', 'LONG_RUNS', 'RESULTS',
           'REPOSITORY']

Row = Sequence[Any]
REPOSITORY = pathlib.Path(__file__).resolve().parents[1]
"""The clone the studies belong to: the report's root unless told otherwise."""
LONG_RUNS = pathlib.Path('docs') / 'long_runs.md'
"""Hand-written runs too long for every `make bench`, and dated notes: BENCHMARKS.md lists
their titles at the end."""
RESULTS = pathlib.Path('results')
"""Where the raw figures (``bench.json``) and the report's plots lie, under the report's root."""


def table(headers: Sequence[str], rows: Iterable[Row]) -> list[str]:
    """A Markdown table: one line per row, cells as given (strings or numbers)."""
    out = ['| ' + ' | '.join(headers) + ' |', '|' + '---|' * len(headers)]
    out += ['| ' + ' | '.join(str(c) for c in row) + ' |' for row in rows]
    return out


@functools.lru_cache(maxsize=1)
def methods() -> dict[str, dict[str, str]]:
    """Section key -> {'title', 'method'} from methods.yaml."""
    path = pathlib.Path(__file__).with_name('methods.yaml')
    return dict(yaml.safe_load(path.read_text(encoding='utf-8')))


def commit_of(r: dict[str, Any], key: str) -> str:
    """The commit the figures under ``key`` were measured at (``--only`` reruns some), in
    backticks."""
    measured = r.get('measured', {}).get(key, {})
    return f"`{measured['commit'] if 'commit' in measured else r['commit']}`"


def pct(x: float | None, digits: int = 3) -> str:
    """A number, or '' for None."""
    return '' if x is None else f'{x:.{digits}f}'


def spread(seconds: Sequence[float]) -> str:
    """Run times as 'least-most s (median m s)'."""
    return (f'{min(seconds):.2f}-{max(seconds):.2f} s '
            f'(median {statistics.median(seconds):.2f} s)')
