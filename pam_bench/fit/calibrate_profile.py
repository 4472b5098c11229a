"""Whether the recordings pin each fitted parameter down: a profile of the fit's cost.

A standard error from the Jacobian at the optimum reads the cost's curvature there; in a
curved, shallow valley it can be 0.1 % of a parameter the data leave free by tens of percent.
The profile asks the data directly. For each parameter i the fit calls fixed, and each
direction d = -1, +1:

- theta_i is moved to theta_i (1 + d ``PROFILE_MOVE``), clipped to its fit interval (the truth
  lies inside it, so a bound nearer than the move ends that side);
- the other parameters are refitted with theta_i held: chord Gauss-Newton steps on the fit's
  own Jacobian at the optimum without column i (J_o, columns scaled to one), dz_o minimising
  |r(z) + J_o dz_o| with z inside the unit interval (``scipy.optimize.lsq_linear``), r
  evaluated on the fit's replay at each step, at most ``PROFILE_STEPS`` steps, stopping once
  the cost no longer falls;
- the move's rise is the fit's sum of squares there minus at the optimum, over the data's
  residual variance s^2 = SSR_data / (m - n) (a chi-square with one degree of freedom when
  the fit is at the noise level).

A move stops early where the data fix the parameter by far: after two evaluated steps, once
the rise less ``PROFILE_TAIL`` times the last step's fall (what the remaining chord steps could
still take off, their falls shrinking at least by a quarter a step) stays ``PROFILE_FAR``
thresholds above ``PROFILE_CHI2``. A second profile, after the fit went on from a lower point,
moves again only what the first did not find fixed by far: a parameter whose two rises were
``PROFILE_FAR`` thresholds or more and which the fit moved by less than a fifth of
``PROFILE_MOVE`` keeps its first profile (its 5 % points lie within 1 % of the new ones, and
the new optimum's lower cost only raises their rises).

A rise below ``PROFILE_CHI2`` on a side moved the whole 5 % means the data reproduce as well
with the parameter 5 % away: it is not fixed within 5 %, and is flagged with the range tried
(a side a bound cut short fixes that side: the truth is not past the bound). The
refit's cost can only be at or above the profile's own minimum, so a flag is never a refit's
shortfall. Every side is evaluated: the linear model of a move (the first chord step, not
evaluated) predicted a rise of 1700 noise variances for a 10 mm muscle's g_m where the
evaluated steps found the cost 35 variances lower (docs/long_runs.md, 'The profile: flagging
what the data do not fix'). A move that ends ``PROFILE_CHI2`` variances or more below the
fit's cost shows the fit stopped short: the caller fits on from it (``profile`` returns it
with its move). Before that fit, ``walk`` goes on the way that move found: the same parameter
another ``PROFILE_MOVE`` of its value at a time, the others refitted by the same chord steps,
while each move lowers the cost by ``PROFILE_CHI2`` noise variances or more. A chord move costs
at most ``PROFILE_STEPS`` evaluations where a fit's step costs a Jacobian (one evaluation per
parameter): a curved, narrow valley that a fit crawls along at 20 evaluations a step (a
10 mm muscle's g_m) is walked 5 % at a time.

Every move is independent: they run through the fit's mapper (the cluster) as one batch.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from scipy.optimize import lsq_linear

from pam_bench.fit.calibrate import residual_variance

__all__ = ['PROFILE_MOVE', 'PROFILE_CHI2', 'PROFILE_STEPS', 'PROFILE_FAR', 'PROFILE_TAIL',
           'WALK_MOVES', 'Move', 'Profile', 'profile_moves', 'run_move', 'profile',
           'kept_profiles', 'walk']

PROFILE_MOVE = 0.05
"""How far each parameter is moved, a share of its value: the 5 % the round trips ask for."""
PROFILE_CHI2 = 4.0
"""A move whose rise (in units of the residual variance) stays below this is within the noise:
two standard deviations of a one-parameter profile."""
PROFILE_STEPS = 4
"""At most this many refit steps (each one evaluation of the replay) per move."""
PROFILE_FAR = 25.0
"""A rise this many times ``PROFILE_CHI2`` (100 noise variances) or more is fixed by far: its
move may stop early, and a second profile keeps it (module docstring)."""
PROFILE_TAIL = 3.0
"""What the chord steps still to come could take off, in units of the last step's fall: the
sum of a geometric series whose falls shrink by a quarter or more a step."""
WALK_MOVES = 8
"""Most moves ``walk`` makes on from a lower point (40 % of the parameter's value)."""


@dataclasses.dataclass(frozen=True)
class Move:
    """One side of one parameter's profile (a cluster job).

    Attributes:
        problem: the fit (``calibrate_bags._Problem``): ``data(z)`` gives the scaled data
            residuals, or None where the models refuse z.
        index: the parameter moved (its column of ``jac``).
        z_moved: its value in z (the unit interval over its fit interval).
        whole: whether it moved the whole ``PROFILE_MOVE`` (False: a bound cut the side short).
        z_opt: the fit's optimum in z, shape (n,).
        z_prior: the prior's centre in z, shape (n,).
        prior_weight: the prior's weight per unit of z.
        jac: the fit's Jacobian at the optimum (data rows, then n prior rows), shape (m+n, n).
        fun: the fit's residuals at the optimum, shape (m+n,).
        s2: the data's residual variance (scaled residual units squared).
    """

    problem: Any
    index: int
    z_moved: float
    whole: bool
    z_opt: np.ndarray
    z_prior: np.ndarray
    prior_weight: float
    jac: np.ndarray
    fun: np.ndarray
    s2: float


@dataclasses.dataclass(frozen=True)
class Profile:
    """One parameter's profile: the values tried below and above (its units), their rises
    (sum of squares over s^2; inf where refused, nan where not tried: a bound), whether the data
    fix it within ``PROFILE_MOVE``, and the replay evaluations spent."""

    name: str
    low: float
    high: float
    rise_low: float
    rise_high: float
    fixed: bool
    evaluations: int

    def line(self, value: float) -> str:
        """The report's line for a parameter the profile leaves free: its range within the
        noise, or, where a move found the cost lower, that the fit did not settle there."""
        lowest = min(r for r in (self.rise_low, self.rise_high) if not math.isnan(r))
        if lowest < 0.0:
            return (f'{value:12.5g}  (not fixed by these recordings: the fit did not settle; '
                    f'{PROFILE_MOVE:.0%} away with the others refitted the cost is '
                    f'{-lowest:.3g} noise variances lower)')
        rises = ', '.join(f'{r:.2g}' for r in (self.rise_low, self.rise_high)
                          if np.isfinite(r))
        return (f'{value:12.5g}  (not fixed by these recordings: from {self.low:.5g} to '
                f'{self.high:.5g}, {PROFILE_MOVE:.0%} either way with the others refitted, the '
                f'cost rises {rises} noise variances, under {PROFILE_CHI2:g})')


def _full(move: Move, z: np.ndarray) -> np.ndarray | None:
    data = move.problem.data(z)
    if data is None:
        return None
    return np.concatenate([data, move.prior_weight * (z - move.z_prior)])


def run_move(move: Move) -> tuple[float, int, np.ndarray]:
    """The rise of one move (module docstring), the evaluations it took and the z it ended
    at; the rise is inf where every trial was refused."""
    rise, used, z, _ = _moved(move)
    return rise, used, z


def _moved(move: Move) -> tuple[float, int, np.ndarray, np.ndarray | None]:
    """``run_move``, and the residuals at the z it ended at (None: every trial refused)."""
    n = len(move.z_opt)
    keep = np.arange(n) != move.index
    jo = move.jac[:, keep]
    norms = np.max(np.abs(jo), axis=0)
    norms = np.where(norms > 0.0, norms, 1.0)
    ssr0 = float(move.fun @ move.fun)

    def step(r: np.ndarray, z_o: np.ndarray) -> np.ndarray:
        """The chord step that keeps every parameter inside its interval."""
        sol = lsq_linear(jo / norms, -r, bounds=(-z_o * norms, (1.0 - z_o) * norms))
        return np.asarray(sol.x) / norms

    z = move.z_opt.copy()
    z[move.index] = move.z_moved
    r = move.fun + move.jac[:, move.index] * (move.z_moved - move.z_opt[move.index])
    best, z_best, r_best, used = np.inf, z.copy(), None, 0
    for _ in range(PROFILE_STEPS):
        z[keep] = np.clip(z[keep] + step(r, z[keep]), 0.0, 1.0)
        trial = _full(move, z)
        used += 1
        if trial is None:
            break
        r = trial
        ssr = float(r @ r)
        if ssr >= best * (1.0 - 1e-3):
            break
        fall, best, z_best, r_best = best - ssr, ssr, z.copy(), r
        if best - ssr0 < PROFILE_CHI2 * move.s2:
            break
        if used >= 2 and best - ssr0 - PROFILE_TAIL * fall > \
                PROFILE_FAR * PROFILE_CHI2 * move.s2:
            break                                   # fixed by far (module docstring)
    return (best - ssr0) / move.s2, used, z_best, r_best


def profile_moves(problem: Any, sol: Any, z_prior: np.ndarray, prior_weight: float,
                  indices: Sequence[int]) -> list[Move]:
    """Both sides of each parameter in ``indices`` (a side at a bound is left out)."""
    n = len(sol.x)
    data = np.asarray(sol.fun)[:-n]
    s2 = max(residual_variance(data, n), 1e-300)
    lower, span = problem.lower, problem.span
    out = []
    for i in indices:
        theta = lower[i] + sol.x[i] * span[i]
        for d in (-1.0, 1.0):
            wanted = (theta * (1.0 + d * PROFILE_MOVE) - lower[i]) / span[i]
            z = float(np.clip(wanted, 0.0, 1.0))
            if abs(z - sol.x[i]) > 1e-12:
                out.append(Move(problem, i, z, z == wanted, np.asarray(sol.x, float), z_prior,
                                prior_weight, np.asarray(sol.jac, float),
                                np.asarray(sol.fun, float), s2))
    return out


def kept_profiles(before: dict[str, Profile], theta_before: np.ndarray,
                  theta: np.ndarray, names: Sequence[str]) -> dict[str, Profile]:
    """The profiles of ``before`` a second profile keeps (module docstring): both rises
    ``PROFILE_FAR`` thresholds or more, and the parameter moved from ``theta_before`` to
    ``theta`` (shape (n,), its units) by less than a fifth of ``PROFILE_MOVE``."""
    far = PROFILE_FAR * PROFILE_CHI2
    out = {}
    for i, n in enumerate(names):
        p = before.get(n)
        if p is None or not p.fixed:
            continue
        rises = [r for r in (p.rise_low, p.rise_high) if not math.isnan(r)]
        moved = abs(theta[i] - theta_before[i]) <= 0.2 * PROFILE_MOVE * abs(theta_before[i])
        if rises and min(rises) >= far and moved:
            out[n] = dataclasses.replace(p, evaluations=0)
    return out


def profile(problem: Any, sol: Any, z_prior: np.ndarray, prior_weight: float,
            names: Sequence[str], skip: Sequence[str],
            mapper: Callable[[Callable[[Any], Any], Any], Any] | None = None,
            kept: dict[str, Profile] | None = None
            ) -> tuple[dict[str, Profile], np.ndarray | None, Move | None]:
    """The profile of every parameter of ``names`` not in ``skip`` (module docstring), its
    moves through ``mapper`` (default: ``map``); the z of the lowest cost a move found
    when it lies ``PROFILE_CHI2`` noise variances or more below the fit's (the fit stopped
    short of a lower point: the caller walks on and fits on from there), else None; and that
    move (None with it). A parameter of ``kept`` (``kept_profiles``) is not moved again: its
    profile is returned as it is."""
    kept = kept or {}
    indices = [i for i, n in enumerate(names) if n not in skip and n not in kept]
    moves = profile_moves(problem, sol, z_prior, prior_weight, indices)
    results = list((mapper or map)(run_move, moves)) if moves else []
    lower, span = problem.lower, problem.span
    out = {}
    for i in indices:
        theta = float(lower[i] + sol.x[i] * span[i])
        sides = [(m, r) for m, r in zip(moves, results, strict=True) if m.index == i]
        value: dict[bool, float] = {True: theta, False: theta}
        rise: dict[bool, float] = {True: math.nan, False: math.nan}
        free = False
        for m, (r, _, _) in sides:
            below = m.z_moved < sol.x[i]
            value[below] = float(lower[i] + m.z_moved * span[i])
            rise[below] = float(r)
            free |= r < PROFILE_CHI2 and m.whole
        out[names[i]] = Profile(names[i], value[True], value[False], rise[True], rise[False],
                                not free, sum(n for _, (_, n, _) in sides))
    out.update({n: p for n, p in kept.items() if n not in skip})
    k = min(range(len(results)), key=lambda j: results[j][0], default=None)
    if k is None or not results[k][0] <= -PROFILE_CHI2:
        return out, None, None
    return out, results[k][2], moves[k]


def walk(move: Move, z_from: np.ndarray) -> tuple[np.ndarray, int]:
    """Go on from ``z_from``, where ``move`` found the cost lower (module docstring): move
    the same parameter on by ``PROFILE_MOVE`` of its value at a time, the others refitted by
    chord steps on the fit's Jacobian, while each move lowers the cost by ``PROFILE_CHI2``
    noise variances or more; at most ``WALK_MOVES`` moves, and a bound or a refused trial ends
    it. Returns the z reached, shape (n,), and the evaluations spent."""
    i = move.index
    r = _full(move, z_from)
    used = 1
    if r is None:
        return z_from, used
    lower, span = move.problem.lower[i], move.problem.span[i]
    d = math.copysign(1.0, move.z_moved - move.z_opt[i])
    z = np.asarray(z_from, float)
    for _ in range(WALK_MOVES):
        wanted = (lower + z[i] * span) * (1.0 + d * PROFILE_MOVE)
        z_i = float(np.clip((wanted - lower) / span, 0.0, 1.0))
        if abs(z_i - z[i]) <= 1e-12:
            break
        rise, n, z_new, r_new = _moved(dataclasses.replace(move, z_opt=z, z_moved=z_i, fun=r))
        used += n
        if r_new is None or not rise <= -PROFILE_CHI2:
            break
        z, r = z_new, r_new
    return z, used
