"""What a benchmark study is: one object each study module exports as ``STUDY``.

A study measures (``measure``: figures for one or more keys of bench.json), renders one
section per key it fills (``sections``: the key, its title and method in methods.yaml, and a
table renderer) and names its headline figures (``results``: rows of the key results). The
suite, the report and the CLI loop over ``benchmarks.studies.STUDIES``, the one list.
"""

from __future__ import annotations

import dataclasses
import pathlib
from collections.abc import Callable
from typing import Any

from benchmarks.tables import Row

__all__ = ['Study', 'Section', 'Measure']

Measure = Callable[[bool, pathlib.Path, 'list[str] | None'], dict[str, Any]]
"""(quick, scratch folder, scenes asked for) -> {bench.json key: figures}."""
Section = Callable[[dict[str, Any], pathlib.Path], list[str]]
"""(the whole report, where plots go) -> Markdown lines of one section."""


def _no_results(r: dict[str, Any]) -> list[Row]:
    return []


@dataclasses.dataclass(frozen=True)
class Study:
    """One study (module docstring).

    Attributes:
        key: its name for ``python -m benchmarks --only``.
        text: what it measures, one line (CLI help).
        measure: runs it.
        sections: (bench.json key, renderer) of each section it fills, in report order.
        results: its rows of the key results (figure, goal, measured, commit).
        quick: whether ``python -m benchmarks --quick`` runs it (False: a quick run has its
            figures from another study, or they need the full run).
    """

    key: str
    text: str
    measure: Measure
    sections: tuple[tuple[str, Section], ...]
    results: Callable[[dict[str, Any]], list[Row]] = _no_results
    quick: bool = True

    @property
    def fills(self) -> tuple[str, ...]:
        """The bench.json keys it writes."""
        return tuple(k for k, _ in self.sections)
