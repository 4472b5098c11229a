"""000's straight-fibre prototype (section 2.3) against the readings of a straight-fibre
campaign (scenes straight_fibre_quick / straight_fibre_4_quick).

000 reports, at 0.22 MPa, for its 250 mm muscle of 3 and 4 segments: the contraction ratio
under 10 N and 150 N (isotonic, "maximum contraction") and the force at 0 % and 14.4 %
contraction (isometric, "maximum force"). The bench's figure is the reading at the top of the
sweep (u = 2.2 V with k_v = 0.1 MPa/V, loading branch). Tolerances: 2.5 points of contraction
ratio; the force at 0 % within 25 % (3 segments) or 10 % (4), at 14.4 % within 15 %: the
three constants of ``pam_bench.models.straight_fibre_muscle`` are one set for both versions
and cannot meet all eight figures closer (its docstring; BENCHMARKS.md, 'The straight-fibre
muscle').
"""

from __future__ import annotations

from typing import Any

import numpy as np

from pam_bench.bags.bagread import Points

__all__ = ['PROTOTYPE', 'prototype_figures']

# segments -> [(figure, protocol kind, series value SI, 000's value, unit, tolerance, relative)]
PROTOTYPE: dict[int, list[tuple[str, str, float, float, str, float, bool]]] = {
    3: [('contraction at 10 N', 'isotonic', 10.0, 0.181, '-', 0.025, False),
        ('contraction at 150 N', 'isotonic', 150.0, 0.148, '-', 0.025, False),
        ('force at 0 %', 'isometric', 0.0, 558.0, 'N', 0.25, True),
        ('force at 14.4 %', 'isometric', 0.036, 127.0, 'N', 0.15, True)],
    4: [('contraction at 10 N', 'isotonic', 10.0, 0.153, '-', 0.025, False),
        ('contraction at 150 N', 'isotonic', 150.0, 0.111, '-', 0.025, False),
        ('force at 0 %', 'isometric', 0.0, 433.0, 'N', 0.10, True),
        ('force at 14.4 %', 'isometric', 0.036, 35.0, 'N', 0.15, True)],
}
TOP_V = 2.2
"""The valve voltage of 0.22 MPa, V."""


def _top(points: Points, series_value: float) -> tuple[float, float]:
    """(contraction m, force N) of the first reading at the top voltage in that series."""
    at = np.flatnonzero(np.isclose(points.series_value, series_value, atol=1e-6)
                        & np.isclose(points.voltage_v, TOP_V, atol=1e-6))
    if not len(at):
        raise ValueError(f'{points.protocol}: no reading at {TOP_V} V in series {series_value}')
    i = int(at[0])
    return float(points.contraction_m[i]), float(points.force_n[i])


def prototype_figures(points: dict[str, Points], segments: int,
                      free_length_m: float = 0.25) -> list[dict[str, Any]]:
    """The figures of ``PROTOTYPE[segments]`` read from a campaign's points (protocol name ->
    Points); one dict per figure: figure, paper, bench, unit, error, tolerance, ok.

    Raises:
        ValueError: a protocol or a reading the figures need is missing.
    """
    out = []
    for figure, kind, value, paper, unit, tol, relative in PROTOTYPE[segments]:
        found = [p for name, p in points.items() if name.startswith(kind)]
        if not found:
            raise ValueError(f'no {kind} readings: the figures need a straight-fibre campaign')
        x, f = _top(found[0], value)
        bench = f if unit == 'N' else x / free_length_m
        error = (bench - paper) / paper if relative else bench - paper
        out.append({'segments': segments, 'figure': figure, 'paper': paper, 'bench': bench,
                    'unit': unit, 'error': error, 'relative': relative, 'tolerance': tol,
                    'ok': abs(error) <= tol})
    return out
