"""The straight-fibre muscle of 000 (Durante et al.): its dimensionless correlation graph and
the sizing procedure built on it (``pam-bench size straight-fibre``).

A silicone tube with axial glass fibres in its wall is divided by N rings into N + 1 segments
of length L0 = L_m0 / (N + 1) (000 section 3.2, step 2). Dimensional analysis (000 Table 3)
leaves three groups: pi_1 = dL / L0 (contraction ratio of a segment), pi_2 = Phi0 / L0
(diameter over segment length) and pi_3 = P L0^2 / F (pressure P in Pa, F in N). 000's Table
4 gives pi_1 from 27 finite-element runs on a grid of pi_2 in {0.25, 0.375, 0.5} and pi_3 in
{1.2 .. 2880}; the correlation here interpolates it bilinearly in (pi_2, log10 pi_3), so it
returns the table's values exactly at its nodes and is monotone between them. Outside the
grid (000: 0.25 <= Phi0 / L0 <= 0.5, and the tabulated pi_3) it refuses instead of
extrapolating.

Wall thickness s (000 Table 6: K_S = 0.11, 0.22, 0.44 at s = 1, 2, 4 mm; linear, 0.11 per
mm): 000 step 3 prints the correction as "dLc = dL K_S x L0". Read here as
dLc / L0 = (dL / L0) (1 - K_S): the thickness takes away the share K_S of the contraction,
the only reading that keeps the corrected contraction positive and below the uncorrected one
for every tabulated s. The muscle's contraction is dL_m = dLc (N + 1) (step 5). Thicknesses
outside 1..4 mm are refused (the table does not cover them; 000's own prototype has 6 mm).

As a force law (``Correlation``, ``force``, ``LAW``): at gauge pressure p (Pa) and muscle
contraction ratio eps = dL_m / L_m0, the graph is read backwards. With the segment's ratio
r = eps / k + r0, the column of the graph at Phi0 / L0 gives log10 pi_3 = lambda(r) (piecewise
linear between the table's rows, each column being strictly increasing in pi_3, and continued
with its end segments beyond them), and F = c p L0^2 10^(-lambda(r)). k = 1 - K_S s, r0 = 0,
c = 1 is 000's procedure as printed (step 3 and 6): then ``force`` and ``size`` are inverse to
each other. k, r0 and c free let the same law follow a muscle the graph does not cover: 000's
own prototype (6 mm wall) is reached with one set for its 3- and 4-segment versions
(``pam_bench.models.straight_fibre_muscle``). In the zoo's law (``LAW``) L0 is the nominal
length l0 (a segment count only rescales c), Phi0 / L0 is fitted and c by its log10.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from pam_bench.models.laws.base import ForceLaw
from pam_bench.vocabulary.errors import ParameterError

__all__ = ['PI2', 'PI3', 'TABLE4', 'K_S_PER_MM', 'contraction_ratio', 'SizeResult', 'size',
           'Design', 'designs_for', 'Correlation', 'force', 'LAW']

PI2 = (0.25, 0.375, 0.5)
"""Phi0 / L0 of the table's columns."""
PI3 = (1.2, 1.44, 1.8, 2.4, 3.6, 7.2, 28.8, 288.0, 2880.0)
"""P L0^2 / F of the table's rows (ascending)."""
TABLE4 = np.array([          # dL / L0 at (pi_3 row, pi_2 column), 000 Table 4
    [0.088, 0.11, 0.12],
    [0.119, 0.138, 0.145],
    [0.159, 0.171, 0.173],
    [0.209, 0.212, 0.207],
    [0.27, 0.26, 0.246],
    [0.343, 0.3184, 0.292],
    [0.409, 0.369, 0.332],
    [0.43, 0.386, 0.344],
    [0.433, 0.387, 0.345],
])
K_S_PER_MM = 0.11
"""Thickness correction per mm of wall (000 Table 6), for 1 <= s <= 4 mm."""


def contraction_ratio(pi2: float, pi3: float) -> float:
    """Contraction ratio dL / L0 of the graph at (Phi0 / L0, P L0^2 / F), bilinear in
    (pi_2, log10 pi_3).

    Raises:
        ParameterError: outside the graph (0.25..0.5, 1.2..2880).
    """
    if not PI2[0] <= pi2 <= PI2[-1]:
        raise ParameterError(f'Phi0/L0 = {pi2:.4g} outside the correlation graph '
                             f'({PI2[0]} .. {PI2[-1]}, 000 section 3.2)')
    if not PI3[0] <= pi3 <= PI3[-1]:
        raise ParameterError(f'P L0^2 / F = {pi3:.4g} outside the correlation graph '
                             f'({PI3[0]} .. {PI3[-1]}, 000 Table 4)')
    logs = np.log10(PI3)
    row = np.array([np.interp(pi2, PI2, TABLE4[i]) for i in range(len(PI3))])
    return float(np.interp(math.log10(pi3), logs, row))


@dataclasses.dataclass(frozen=True)
class SizeResult:
    """A forward sizing: the groups, the segment's ratio, corrected, and the muscle's stroke."""

    segment_length_m: float
    phi0_over_l0: float
    p_l0sq_over_f: float
    segment_ratio: float              # dL / L0 from the graph
    thickness_factor: float           # 1 - K_S
    contraction_ratio: float          # dLc / L0 = dL_m / L_m0
    contraction_m: float              # dL_m


def size(diameter_m: float, length_m: float, segments: int, wall_m: float, force_n: float,
         pressure_pa: float) -> SizeResult:
    """000's procedure, forward: the contraction of a muscle of free length ``length_m`` with
    ``segments`` segments, diameter ``diameter_m``, wall ``wall_m`` under ``force_n`` at gauge
    pressure ``pressure_pa``.

    Raises:
        ParameterError: a non-positive size, a wall outside 1..4 mm, or the groups outside the
            graph (the message says which).
    """
    if not (diameter_m > 0 and length_m > 0 and force_n > 0 and pressure_pa > 0
            and segments >= 1):
        raise ParameterError('size: diameter, length, force and pressure must be > 0 and '
                             'segments >= 1')
    wall_mm = wall_m * 1e3
    if not 1.0 - 1e-9 <= wall_mm <= 4.0 + 1e-9:
        raise ParameterError(f'wall {wall_mm:g} mm outside the thickness table (1 .. 4 mm, '
                             '000 Table 6)')
    l0 = length_m / segments
    pi2, pi3 = diameter_m / l0, pressure_pa * l0 ** 2 / force_n
    ratio = contraction_ratio(pi2, pi3)
    factor = 1.0 - K_S_PER_MM * wall_mm
    corrected = ratio * factor
    return SizeResult(l0, pi2, pi3, ratio, factor, corrected, corrected * length_m)


@dataclasses.dataclass(frozen=True)
class Design:
    """A muscle that meets a target (inverse sizing): sizes in m, its groups and stroke."""

    diameter_m: float
    length_m: float
    segment_length_m: float
    phi0_over_l0: float
    p_l0sq_over_f: float
    segment_ratio: float              # dL / L0 read from the graph
    contraction_ratio: float          # after the wall correction
    contraction_m: float


def designs_for(force_n: float, contraction_m: float, pressure_pa: float, segments: int,
                wall_m: float, pi2_values: tuple[float, ...] | None = None) -> list[Design]:
    """000's procedure, inverse: for each Phi0 / L0 of ``pi2_values`` (default 0.25 .. 0.5 in
    steps of 0.025), the segment length L0 whose muscle of ``segments`` segments and wall
    ``wall_m`` contracts by ``contraction_m`` under ``force_n`` at ``pressure_pa``.

    The stroke (1 - K_S) r(pi_2, P L0^2 / F) (N + 1) L0 grows with L0 (the graph's ratio grows
    with P L0^2 / F), so each L0 is found by bisection inside the graph; a Phi0 / L0 for which
    no L0 in the graph reaches the target gives no design.

    Raises:
        ParameterError: a non-positive target or a wall outside 1..4 mm.
    """
    if not (force_n > 0 and contraction_m > 0 and pressure_pa > 0 and segments >= 1):
        raise ParameterError('size: force, contraction and pressure must be > 0, segments >= 1')
    factor = 1.0 - K_S_PER_MM * wall_m * 1e3
    if not 1.0 - 1e-9 <= wall_m * 1e3 <= 4.0 + 1e-9:
        raise ParameterError(f'wall {wall_m * 1e3:g} mm outside the thickness table (1 .. 4 '
                             'mm, 000 Table 6)')
    grid = pi2_values or tuple(np.round(np.arange(0.25, 0.5001, 0.025), 3))
    lo0, hi0 = math.sqrt(PI3[0] * force_n / pressure_pa), math.sqrt(PI3[-1] * force_n /
                                                                      pressure_pa)
    out = []
    for pi2 in grid:
        def stroke(l0: float, pi2: float = pi2) -> float:
            pi3 = min(max(pressure_pa * l0 * l0 / force_n, PI3[0]), PI3[-1])
            return factor * contraction_ratio(pi2, pi3) * segments * l0

        lo, hi = lo0, hi0
        if not stroke(lo) <= contraction_m <= stroke(hi):
            continue
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if stroke(mid) < contraction_m else (lo, mid)
        l0 = 0.5 * (lo + hi)
        pi3 = pressure_pa * l0 * l0 / force_n
        ratio = contraction_ratio(pi2, pi3)
        out.append(Design(pi2 * l0, segments * l0, l0, pi2, pi3, ratio, factor * ratio,
                          stroke(l0)))
    return out


_LOG_PI3 = tuple(math.log10(v) for v in PI3)


class Correlation:
    """The graph's column at one Phi0 / L0 and its inverse lambda(r) = log10 pi_3 (module
    docstring): piecewise linear in r between the rows, continued with the end segments."""

    def __init__(self, pi2: float) -> None:
        """Raises: ParameterError: ``pi2`` outside 0.25 .. 0.5."""
        if not PI2[0] <= pi2 <= PI2[-1]:
            raise ParameterError(f'Phi0/L0 = {pi2:.4g} outside the correlation graph '
                                 f'({PI2[0]} .. {PI2[-1]}, 000 section 3.2)')
        self.pi2 = pi2
        self.ratios = tuple(float(np.interp(pi2, PI2, TABLE4[i])) for i in range(len(PI3)))

    def log_pi3(self, ratio: float) -> tuple[float, float]:
        """(lambda(r), d lambda / dr) at the segment's contraction ratio r."""
        rs, ls = self.ratios, _LOG_PI3
        i = 0
        last = len(rs) - 2
        while i < last and ratio > rs[i + 1]:
            i += 1
        slope = (ls[i + 1] - ls[i]) / (rs[i + 1] - rs[i])
        return ls[i] + slope * (ratio - rs[i]), slope


def _lambda(pi2: float, ratio: np.ndarray) -> np.ndarray:
    """lambda(r) of ``Correlation`` for an array of r (any pi2 in 0.25 .. 0.5)."""
    rs = np.array([np.interp(pi2, PI2, TABLE4[i]) for i in range(len(PI3))])
    ls = np.array(_LOG_PI3)
    lo = ls[0] + (ls[1] - ls[0]) / (rs[1] - rs[0]) * (ratio - rs[0])
    hi = ls[-1] + (ls[-1] - ls[-2]) / (rs[-1] - rs[-2]) * (ratio - rs[-1])
    return np.where(ratio < rs[0], lo, np.where(ratio > rs[-1], hi, np.interp(ratio, rs, ls)))


def force(th: np.ndarray, p: np.ndarray, x: np.ndarray, l0: float) -> np.ndarray:
    """The graph read backwards (module docstring) with th = (Phi0 / L0, k, r0, log10 c),
    L0 = l0; N. c is fitted by its logarithm: it scales the force over decades."""
    pi2, k, r0, log_c = th
    lam = _lambda(float(pi2), x / l0 / k + r0)
    return np.maximum(p, 0.0) * l0 * l0 * 10.0 ** (log_c - np.minimum(lam, 300.0))


LAW = ForceLaw('straight_fibre', '000 Table 4 (graph read backwards)',
               ('phi0_over_l0', 'k', 'r0', 'log10_c'), (0.375, 1.0, 0.1, -1.0),
               (0.25, 0.05, -0.5, -4.0), (0.5, 3.0, 0.5, 3.0), force)
