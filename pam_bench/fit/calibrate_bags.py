"""Fit the bench's muscle and valve to a lab's own recordings (``pam-bench calibrate BAG``).

The readings and records are replayed on the simulated bench (``fit.calibrate_replay``:
how, and how the residuals are scaled); the fit starts from values read off the data
(``fit.calibrate_init``) and ends with a verdict against the noise
(``fit.calibrate_verdict``).

- Residuals: forces in units of 1 % of the load cell's 2000 N range (20 N), contractions in
  0.5 mm. ``scipy.optimize.least_squares`` (trust region reflective) fits the parameters of
  ``FREE_BAGS`` inside their bounds (the declared ranges narrowed for the reasons of
  ``BOUND_REASONS``), each normalised to z in [0, 1].
- Prior: one residual ``PRIOR_WEIGHT`` (z - z_0) per parameter, so crossing a parameter's
  whole range costs as much as one reading one noise deviation off (0.2 N against the 20 N
  scale): it keeps what the data do not fix near its start and leaves what they fix alone.
- Errors and flags: standard errors and correlations from the Jacobian at the optimum
  (``calibrate.fit_summary``, the prior's rows included). A parameter is flagged (the
  recordings do not fix it) when its error exceeds 5 % of its value, when it sits at a bound,
  when the data alone leave it a variance above ``UNFIXED_SHARE`` of its interval squared
  ([(J^T J + delta I)^-1]_ii in z, delta = ``DATA_ONLY``), when the data alone (the residuals'
  variance, without the prior, which shrinks the error of what the data do not see) leave it a
  standard error above ``UNFIXED_REL`` of its value, or when its data-only correlation with a
  flagged parameter reaches ``JOINT_CORRELATION``. Every parameter left fixed then has its
  profile taken (``fit.calibrate_profile``): moved 5 % either way with the others refitted, a
  rise of the cost within the noise flags it too, with the range tried; a move that found the
  cost well below the fit's shows the fit stopped short, and it walks on the way that move
  went (``calibrate_profile.walk``) and fits on from there (at most ``PROFILE_REFITS`` times).
- A bag of more than ``COARSE_READINGS`` readings is first fitted on every k-th series
  (``coarse``), and that fit is profiled and walked the same way before the fit on every
  reading starts from it: a curved valley (a 10 mm muscle's g_m) is walked at the subset's
  cost per evaluation instead of crawled by the whole bag's Jacobians. A parameter the
  subset's profile fixes by far, and which the fit on every reading moves by less than 1 %,
  keeps that profile (``calibrate_profile.kept_profiles``): more readings only raise its rises.
- Settling: when the Gauss-Newton step from the fit's end would still move a parameter by more
  than ``SETTLED_STEP`` of its value, the fit goes on for a few evaluations without the early
  stop, its Jacobian by central differences (``SETTLE_JAC``; ``_settled``). Jacobian steps are
  ``DIFF_STEP`` of each interval; a trial past the muscle's stability rule stops a fit
  (``RISE_MARGIN``).
- Left out: a reading at held load whose friction loop at the starting parameters is wider than
  ``PATH_WIDTH_M`` in contraction (no replay places it: its transient decides it); they are
  listed.

Why each of these is as it is (the drawn sets that moved the prior, the flags, the central
differences and the step): docs/long_runs.md, 'Calibrate: how the fit's rules were chosen'.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from pam_bench.fit.calibrate import FitSummary, fit_report, fit_summary, residual_variance
from pam_bench.fit.calibrate_init import initial_values, law_start
from pam_bench.fit.calibrate_profile import (
    PROFILE_CHI2,
    Profile,
    kept_profiles,
    profile,
    walk,
)
from pam_bench.fit.calibrate_replay import (
    CONTRACTION_SCALE_M,
    FORCE_SCALE_N,
    PATH_WIDTH_M,
    RECORD_STRIDE,
    Bench,
    Observations,
    _compiled_core,
    observations_from_bags,
    observations_from_twin,
    path_sensitive,
    predict,
    residuals,
    rms_by_kind,
    rms_of,
)
from pam_bench.fit.calibrate_verdict import noise_levels, verdict
from pam_bench.models.errors import ModelError
from pam_bench.models.laws.base import ForceLaw
from pam_bench.models.loading_servo import LoadingServoParams
from pam_bench.models.muscle import MuscleParams, gain_rise_limit
from pam_bench.models.valve import ValveParams
from pam_bench.vocabulary.errors import ParameterError

__all__ = ['FREE_BAGS', 'BOUND_REASONS', 'Observations', 'Bench', 'observations_from_bags',
           'observations_from_twin', 'predict', 'calibrate_bags', 'overlay_of',
           'FORCE_SCALE_N', 'CONTRACTION_SCALE_M', 'PATH_WIDTH_M', 'path_sensitive',
           'calibrate_bag', 'run_start', 'Mapper', 'reached', 'coarse', 'free_of_law',
           'rms_by_kind', 'bench_of_scene', 'bench_of_settings', 'bench_of_bags', 'Calibration',
           'check_observations']


class Calibration(FitSummary):
    """``calibrate_bags``' result (``--json`` prints it without the two parameter objects):
    the fit (``FitSummary``, held parameters appended and flagged), the fitted bench
    (``valve``, ``muscle``, ``laws``: the law's settings or None), RMS per protocol kind
    before and after (N or mm), the verdict (``Verdict.as_dict``), the noise levels, every
    law's static RMS on the isometric readings best first (N), the law fitted (None: the
    bench's McKibben), the start values and what each was read from, the held values and
    why, the starts tried and how many reached the best, the readings left out (kind, u V,
    held value), each profiled parameter's ``calibrate_profile.Profile`` as a dict, the cost,
    evaluations and seconds taken."""

    valve: ValveParams
    muscle: MuscleParams
    laws: Any
    rms_before: dict[str, float]
    rms_after: dict[str, float]
    verdict: dict[str, Any]
    noise: dict[str, float]
    law_zoo: dict[str, float]
    law: str | None
    start: dict[str, float]
    start_from: dict[str, str]
    held: dict[str, str]
    starts: dict[str, int]
    left_out: list[Any]
    profile: dict[str, dict[str, Any]]
    cost: float
    evaluations: int
    fit_s: float


PRIOR_WEIGHT = 0.01             # a range costs one reading a noise deviation off (docstring)
UNFIXED_SHARE = 0.01            # data-only variance in z at the tolerances that flags
UNFIXED_REL = 0.05              # data-only standard error, share of the value, that flags
REFUSED_RESIDUAL = 1.0e3        # the stand-in residual of a refused trial (tolerances)
DATA_ONLY = 1e-6                # the ridge that keeps J^T J invertible (module docstring)
JOINT_CORRELATION = 0.95        # fixed only jointly with a flagged parameter: flagged too

FREE_BAGS: tuple[tuple[str, str, float, float], ...] = (
    ('muscle', 'gain_n_per_pa', 5.0e-4, 6.0e-3),
    ('muscle', 'gain_min_n_per_pa', 2.0e-5, 5.0e-4),
    ('muscle', 'gain_min_contraction_m', 0.05, 0.13),
    ('muscle', 'gain_exponent', 1.1, 4.0),
    ('muscle', 'gain_rise_n_per_pa_m', 0.0, 1.0e-3),
    ('muscle', 'threshold_pressure_pa', 2.0e4, 1.5e5),
    ('muscle', 'threshold_width_pa', 0.0, 8.0e4),
    ('muscle', 'bladder_stiffness_n_per_m', 250.0, 1500.0),
    ('muscle', 'stretch_stiffness_n_per_m', 5.0e4, 1.0e6),
    ('muscle', 'friction_stiffness_scale', 0.2, 3.0),
    ('valve', 'natural_frequency_rad_s', 20.0, 300.0),
    ('valve', 'damping_ratio', 0.05, 1.2),
)
"""(model, parameter, lower, upper); ``friction_stiffness_scale`` multiplies every friction
element's stiffness (calibrate.FREE). Each interval lies inside the parameter's declared range
(``MuscleParams``, ``ValveParams``; a test checks it) and is narrowed only for the reason
``BOUND_REASONS`` gives."""

BOUND_REASONS: dict[str, str] = {
    'gain_n_per_pa': "50 to 600 N/V at 0.1 MPa/V: from a 10 mm muscle of 004's braid (a quarter "
                     "of 004's 284.3 N/V) to one twice 004's; the declared 0..1 N/Pa is any "
                     'muscle',
    'gain_min_n_per_pa': "2 to 50 N/V at 0.1 MPa/V (004: 17.4 N/V at 95 mm; a 10 mm muscle's "
                         'a quarter of it)',
    'gain_min_contraction_m': "50 to 130 mm: inside the muscle's stroke (Key results: 131 mm "
                              'at 6 V, 50 N)',
    'gain_exponent': 'a curve that falls from g_0 to g_m at all (n > 1) and not as a step '
                     '(n <= 4)',
    'gain_rise_n_per_pa_m': 'from none to 100 N/V per metre past x_m',
    'threshold_pressure_pa': '0.2 to 1.5 V of command at 0.1 MPa/V',
    'threshold_width_pa': 'the declared lower end (0: a sharp threshold) up to a band 0.8 V '
                          'wide',
    'bladder_stiffness_n_per_m': 'the rubber tube alone, 0.25 to 1.5 N/mm',
    'stretch_stiffness_n_per_m': 'the braid pulled past its rest length, 50 to 1000 N/mm',
    'friction_stiffness_scale': 'the friction elements 5 times softer to 3 times stiffer',
    'natural_frequency_rad_s': "a valve loop of 3.2 to 48 Hz (the bench's default: 5 Hz)",
    'damping_ratio': 'from a ringing loop (0.05) to an over-damped one (1.2)',
}
"""The physical argument for each fit interval narrower than the declared range."""


Free = tuple[tuple[str, str, float, float], ...]
"""(model: 'valve', 'muscle' or 'law', name, lower, upper) of each free parameter; a law's
parameter is named 'LAW.PARAMETER'."""


def free_of_law(law: ForceLaw) -> Free:
    """The free parameters of a fit with the force law ``law`` as the muscle: the law's own
    (its declared bounds), the friction's stiffness scale and the valve's loop.

    Raises:
        ModelError: a parameter of the law without a finite interval to fit in.
    """
    rows = []
    for n, lo, hi in zip(law.params, law.lower, law.upper, strict=True):
        if not (math.isfinite(lo) and math.isfinite(hi) and hi > lo):
            raise ModelError(f'force law {law.name}: parameter {n} has no finite interval '
                             f'[{lo}, {hi}] to fit in')
        rows.append(('law', f'{law.name}.{n}', float(lo), float(hi)))
    return tuple(rows) + tuple(f for f in FREE_BAGS if f[0] == 'valve' or
                               f[1] == 'friction_stiffness_scale')


LAW_FORCE_STEP = 0.01
"""A law parameter's finite-difference step moves the law's forces over the isometric readings
by this share of their RMS (``law_steps``)."""


def law_steps(law: ForceLaw, free: Free, readings: Sequence[tuple[str, float, float, float]],
              theta: np.ndarray, kv: float, l0: float) -> np.ndarray:
    """Each free parameter's finite-difference step in z, shape (n,): ``DIFF_STEP`` (1 % of its
    fit interval), or for a parameter of ``law`` less where that moves the law's forces more
    than ``LAW_FORCE_STEP`` of their RMS over the isometric readings (pressure k_v u, Pa;
    contraction x, m; l0 m) at ``theta`` (shape (n,), the start). A plug-in's interval may be
    a placeholder for 'unbounded' (002's law: +-1e5 for a parameter near 1 N): 1 % of it is a
    step of 2000 N, the Jacobian is blind and the fit ends where it started (docs/long_runs.md,
    'A law with wide bounds: the fit's step scaled to its forces'). The fit's trust region is
    scaled alike (``_local_fit``)."""
    steps = np.full(len(free), DIFF_STEP)
    iso = [(u, x) for kind, u, x, _ in readings if kind == 'isometric']
    if not iso:
        return steps
    u, x = (np.array(c, float) for c in zip(*iso, strict=True))
    p = kv * u
    names = [f'{law.name}.{n}' for n in law.params]
    at = {i: names.index(f[1]) for i, f in enumerate(free) if f[0] == 'law' and f[1] in names}
    th = np.array(law.start, float)
    for i, k in at.items():
        th[k] = theta[i]

    def rms(v: np.ndarray) -> float:
        return float(np.sqrt(np.mean(np.asarray(v, float) ** 2)))
    with np.errstate(all='ignore'):
        scale = rms(law.law(th, p, x, l0))
        if not (math.isfinite(scale) and scale > 0.0):
            return steps
        for i, k in at.items():
            span = free[i][3] - free[i][2]
            d = 1e-6 * max(abs(th[k]), 1e-6 * span, 1e-12)
            up, down = th.copy(), th.copy()
            up[k] += d
            down[k] -= d
            slope = rms((np.asarray(law.law(up, p, x, l0), float)
                         - np.asarray(law.law(down, p, x, l0), float)) / (2.0 * d))
            if math.isfinite(slope) and slope > 0.0:
                steps[i] = min(DIFF_STEP, max(LAW_FORCE_STEP * scale / slope / span, 1e-9))
    return steps


RISE_MARGIN = 0.99
"""A fitted gain rise is clamped to this share of the most the muscle's stability allows
(g_r 1 MPa < k_bl, ``models.muscle``): a trial or a finite-difference step across the rule
then reads a flat slope instead of a refused model, whose stand-in residual (1e3 tolerances)
shrank the trust region and stopped a fit next to the rule, 16 % off in the threshold band
and at three times the true parameters' cost (the gain at the lower end of its interval, a
soft bladder: the round-trip study)."""


def _bench(theta: np.ndarray, base: Bench, free: Sequence[tuple[str, str, float, float]]
           ) -> Bench:
    """``base`` with the values ``theta`` of the ``free`` parameters put in, the gain's rise
    clamped inside the muscle's stability rule (``RISE_MARGIN``)."""
    v: dict[str, Any] = {}
    m: dict[str, Any] = {}
    laws: dict[str, dict[str, float]] = {}
    for (model, name, _, _), value in zip(free, theta, strict=True):
        if model == 'law':
            law, param = name.split('.', 1)
            laws.setdefault(law, {})[param] = float(value)
        else:
            (v if model == 'valve' else m)[name] = float(value)
    scale = m.pop('friction_stiffness_scale', None)
    if scale is not None:
        m['friction_stiffness_n_per_m'] = [k * scale
                                           for k in base.muscle.friction_stiffness_n_per_m]
    new_laws = base.laws
    if laws:
        from pam_bench.config.settings import LawSettings
        new_laws = dataclasses.replace(base.laws if base.laws is not None else LawSettings(),
                                       **{law: dataclasses.replace(
                                           getattr(base.laws or LawSettings(), law), **vals)
                                           for law, vals in laws.items()})
    muscle = dataclasses.replace(base.muscle, **m)
    most = RISE_MARGIN * gain_rise_limit(muscle.bladder_stiffness_n_per_m)
    if 'gain_rise_n_per_pa_m' in m and muscle.gain_rise_n_per_pa_m > most:
        muscle = dataclasses.replace(muscle, gain_rise_n_per_pa_m=most)
    return Bench(dataclasses.replace(base.valve, **v), muscle, base.servo, new_laws)


def _models(theta: np.ndarray, valve: ValveParams, muscle: MuscleParams,
            free: Sequence[tuple[str, str, float, float]] = FREE_BAGS
            ) -> tuple[ValveParams, MuscleParams]:
    """The valve and muscle with the values ``theta`` of the ``free`` parameters."""
    b = _bench(theta, Bench(valve, muscle), free)
    return b.valve, b.muscle


Mapper = Callable[[Callable[[Any], Any], Any], Any]
"""A map-like callable: ``map``, or ``cluster.layer.map_on(client)``."""
STARTS_SEED = 2026
REFINE_NFEV = 30
"""Evaluations of each start's local fit (on the static replay, the fast one)."""
STOP_SHARE = 0.25
"""A local fit stops once every protocol's RMS is within this share of its noise level
(``calibrate_verdict``): the parameters then sit well inside the noise's reach, and the
evaluations after it would only chase the noise."""
STOP_CHI2 = PROFILE_CHI2
"""A local fit with the early stop also stops at an iteration that lowered its chi-square
(twice the cost, in units of the data's residual variance) by less than this, and the
settling fit does not start when the Gauss-Newton step would gain less: the profile's own
measure of what lies within the noise (two standard deviations of one parameter). A 16 mm x
300 mm muscle's identification fit spent its last 5 of 10 iterations, 25 s, gaining half a
variance each (docs/long_runs.md, 'Two more sizes, and a fit that stops when it gains less
than the noise'); a fit that crawls a curved valley gains tens of variances an iteration and
goes on, and the profile and the walk judge where it stopped."""
SETTLED_STEP = 0.01
"""A fit whose Gauss-Newton step from its end, -(J^T J)^+ J^T r, would still move a parameter
by more than this share of its value stopped short (the early stop near the noise level, on a
shallow valley): it goes on without the early stop, for at most ``SETTLE_NFEV`` evaluations
(``_settled``). A fifth of the 5 % the round-trip studies ask for: from the slope of a curved
valley the step reaches only part of the way (docs/long_runs.md, 'The settling check at 1 %')."""
SETTLE_NFEV = 20
PROFILE_REFITS = 1
"""At most this many fits on from a lower point the profile found (``calibrate_profile``): a
10 mm muscle's identification fit walked its curved valley slowly, 252 evaluations for two;
what is still not settled after one is flagged (docs/long_runs.md, 'The profile: flagging
what the data do not fix')."""
SETTLE_JAC = '3-point'
"""The settling fit's finite differences: central (twice the evaluations per Jacobian)."""
DIFF_STEP = 1e-2
"""The finite-difference step of the Jacobian in z (scipy takes it as an absolute step for
|z| < 1): 1 % of each parameter's fit interval. The replay is not smooth below that (a held
span that starts one sub-step later, a friction element that slips one sub-step sooner), and a
step of 0.1 % read that roughness as the slope: a fit then stopped in the curved valley of the
gain curve's minimum, its exponent and x_m, 41 % off in g_m, at a chi-square 45 % above the
true parameters' (BENCHMARKS.md, 'Calibrating the bench to recordings, across the bounds').
It is too long for a parameter the cost is very steep in (the gain at the lower end of its
interval: a step of 1 % moves the cost a thousand-fold and reads its curvature) when the
differences are forward: the settling fit takes central ones (``SETTLE_JAC``). A step per
parameter, shortened where it moves the residuals by more than they are, fixed neither case
(tried, and left)."""
FTOL = 1e-6
"""Relative change of the cost at which a local fit has converged: past it, noise."""
XTOL = 1e-8
"""Relative step in z (the unit interval over each parameter's bounds) that ends a fit."""
BEST_COST_REL = 0.02
"""A start reached the best cost when its cost is within this share of it."""
REFINED_STARTS = 3
"""How many of the multi-start's best (on the static replay) are refined on the fit's own
replay: the static replay's floor (0.75-0.9 N on isometric bags of the zoo's laws, against
0.2 N of noise) can rank the start in the right basin below others."""
COARSE_READINGS = 400
"""Past this many readings, a first fit runs on every k-th series only (``coarse``), and the
fit on all of them starts where it ended."""
ZOO_READINGS = 400
"""The law zoo's hint fits each law to at most this many isometric readings, evenly spread
over them (a hint ranks laws; docs/long_runs.md, "The law zoo's hint on a spread subset")."""


@dataclasses.dataclass(frozen=True)
class _Problem:
    """One fit: what it replays and in which coordinates (z in [0, 1] over the bounds)."""

    obs: Observations
    base: Bench
    free: Free
    left_out: tuple[int, ...]
    replay: str
    steps: np.ndarray | None = None
    """Each parameter's finite-difference step in z (``law_steps``; None: ``DIFF_STEP``)."""

    @property
    def lower(self) -> np.ndarray:
        return np.array([lo for _, _, lo, _ in self.free])

    @property
    def span(self) -> np.ndarray:
        return np.array([hi - lo for _, _, lo, hi in self.free])

    def bench(self, z: np.ndarray) -> Bench:
        return _bench(self.lower + z * self.span, self.base, self.free)

    def data(self, z: np.ndarray, replay: str | None = None) -> np.ndarray | None:
        """Scaled data residuals at z (None where the models refuse it, or where a law gives
        forces no bench could: a residual past ``REFUSED_RESIDUAL`` tolerances, or not
        finite, as a law with an exponential far from its data does)."""
        try:
            out = residuals(self.obs, predict(self.obs, self.bench(z), replay or self.replay),
                            self.left_out)
        except (ModelError, ParameterError):
            return None
        with np.errstate(invalid='ignore'):
            if not np.all(np.abs(out) <= REFUSED_RESIDUAL):
                return None
        return out


def _kind_rms(problem: _Problem, residuals: np.ndarray) -> dict[str, float]:
    """RMS per protocol kind (N or mm) of a residual vector laid out as ``residuals``."""
    kept = [r[0] for i, r in enumerate(problem.obs.readings) if i not in problem.left_out]
    out: dict[str, float] = {}
    for kind in ('isometric', 'isotonic', 'isobaric'):
        mask = np.array([k == kind for k in kept], bool)
        if mask.any():
            scale = FORCE_SCALE_N if kind == 'isometric' else CONTRACTION_SCALE_M * 1e3
            out[kind] = float(np.sqrt(np.mean(residuals[:len(kept)][mask] ** 2))) * scale
    rec = residuals[len(kept):]
    if len(rec):
        out['step_records'] = float(np.sqrt(np.mean(rec ** 2))) * FORCE_SCALE_N
    return out


def _local_fit(problem: _Problem, z_start: np.ndarray, z_prior: np.ndarray, max_nfev: int,
               workers: Mapper | None, replay: str | None = None,
               stop_at: dict[str, float] | None = None, jac: str = '2-point') -> Any:
    """``least_squares`` from ``z_start`` with the weak prior at ``z_prior``; with ``stop_at``
    it stops early once every protocol's RMS is within it (N or mm), or once an iteration
    gains less than ``STOP_CHI2`` noise variances. ``jac``: scipy's
    finite-difference scheme ('2-point' forward, '3-point' central)."""
    n_data = len(problem.obs.readings) - len(problem.left_out) + sum(
        len(r[4][::RECORD_STRIDE]) for r in problem.obs.records)
    n_res = n_data + len(z_start)

    def res(z: np.ndarray) -> np.ndarray:
        data = problem.data(z, replay)
        if data is None:
            return np.full(n_res, REFUSED_RESIDUAL)
        return np.concatenate([data, PRIOR_WEIGHT * (z - z_prior)])

    last_cost = math.inf

    def callback(intermediate_result: Any) -> None:
        nonlocal last_cost
        data = np.asarray(intermediate_result.fun)[:n_data]
        rms = _kind_rms(problem, data)
        if stop_at is not None and rms and all(v <= stop_at.get(k, 0.0) for k, v in
                                               rms.items()):
            raise StopIteration
        cost = float(intermediate_result.cost)
        gained, last_cost = last_cost - cost, cost
        if (stop_at is not None and n_data > len(z_start)
                and 2.0 * gained < STOP_CHI2 * residual_variance(data, len(z_start))):
            raise StopIteration

    steps = problem.steps if problem.steps is not None else DIFF_STEP
    return least_squares(res, z_start, bounds=(0.0, 1.0), diff_step=steps, max_nfev=max_nfev,
                         x_scale=np.asarray(steps) / DIFF_STEP, callback=callback, ftol=FTOL,
                         xtol=XTOL, jac=jac,
                         **({'workers': workers} if workers is not None else {}))


def _gauss_newton(sol: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The Gauss-Newton step from a ``least_squares`` solution on its Jacobian with columns
    scaled to one (a huge column, a law's exponential at a trial, hides none): (column norms,
    scaled Jacobian, step in scaled units), the step in z being step / norms."""
    norms = np.max(np.abs(sol.jac), axis=0)
    norms = np.where(norms > 0.0, norms, 1.0)
    scaled = sol.jac / norms
    return norms, scaled, np.linalg.lstsq(scaled, -sol.fun, rcond=None)[0]


def gauss_newton_share(sol: Any, lower: np.ndarray, span: np.ndarray) -> np.ndarray:
    """The Gauss-Newton step from a ``least_squares`` solution in z, -(J^T J)^+ J^T r, as a
    share of each parameter's value (theta = lower + z span), shape (n,)."""
    norms, _, d = _gauss_newton(sol)
    step = d / norms
    theta = lower + sol.x * span
    return np.where(theta != 0.0, step * span / np.where(theta != 0.0, np.abs(theta), 1.0),
                    0.0)


def gauss_newton_gain(sol: Any, n_data: int) -> float:
    """What the Gauss-Newton step from a ``least_squares`` solution would lower its
    chi-square by on the linearised model, |J d|^2 with d = -(J^T J)^+ J^T r, in units of the
    data's residual variance s^2 = |r_data|^2 / (n_data - n) (``n_data``: how many of the
    residuals are data, the rest being the prior's)."""
    _, scaled, d = _gauss_newton(sol)
    s2 = residual_variance(np.asarray(sol.fun)[:n_data], len(sol.x))
    return float(np.sum((scaled @ d) ** 2)) / s2 if s2 > 0.0 else math.inf


def _settled(problem: _Problem, sol: Any, z_prior: np.ndarray, lower: np.ndarray,
             span: np.ndarray, max_nfev: int, workers: Mapper | None) -> tuple[Any, int]:
    """``sol``, or where a fit from it without the early stop ends when the Gauss-Newton step
    shows it stopped short (it would move a parameter by more than ``SETTLED_STEP`` and lower
    the chi-square by ``STOP_CHI2`` noise variances or more: a step that buys less moves only
    what the data do not fix, and the profile judges that) and that fit's cost is lower; and
    the evaluations it took."""
    if float(np.max(np.abs(gauss_newton_share(sol, lower, span)), initial=0.0)) <= SETTLED_STEP:
        return sol, 0
    if gauss_newton_gain(sol, len(sol.fun) - len(sol.x)) < STOP_CHI2:
        return sol, 0
    more = _local_fit(problem, sol.x, z_prior, min(max_nfev, SETTLE_NFEV), workers,
                      jac=SETTLE_JAC)
    return (more if more.cost < sol.cost else sol), int(more.nfev)


def run_start(job: tuple[_Problem, np.ndarray]) -> tuple[np.ndarray, float]:
    """One start of the multi-start (a cluster job): a local fit on the static replay from the
    start, without a prior; returns its z and its data cost (half the sum of squares)."""
    problem, z = job
    _compiled_core()
    sol = _local_fit(problem, z, z, REFINE_NFEV, None, replay='static')
    data = problem.data(sol.x, 'static')
    cost = 0.5 * float(data @ data) if data is not None else math.inf
    return sol.x, cost


def _space_filling(n: int, d: int, seed: int) -> np.ndarray:
    """``n`` starts over [0, 1]^d, a Latin hypercube (scipy.stats.qmc)."""
    from scipy.stats import qmc
    return qmc.LatinHypercube(d=d, seed=seed).random(n)


def _hints(problem: _Problem, values: dict[str, float], at_bound: Sequence[str]) -> list[str]:
    """What the user could change, from what the fit saw."""
    out = []
    iso_x = [h for k, _, h, _ in problem.obs.readings if k == 'isometric']
    xm = values.get('gain_min_contraction_m', problem.base.muscle.gain_min_contraction_m)
    if iso_x and max(iso_x) < xm and problem.base.muscle.kind == 'mckibben':
        out.append(f'a longer grid (isometric positions past x_m = {xm * 1e3:.0f} mm)')
    if at_bound:
        out.append(f'a freed parameter ({", ".join(at_bound)} at the end of its fit interval)')
    return out


def reached(obs: Observations) -> dict[str, str]:
    """The free parameters no observation can show, each with why: they keep their start
    (fitting them would only spend evaluations on a flat direction). The gain's rise acts past
    x_m only (x_m itself at least the lower end of its interval), the stretch stiffness below
    x = 0 only, the valve's loop only in step records."""
    xs = [h if k == 'isometric' else v for k, _, h, v in obs.readings]
    xm = next(lo for _, n, lo, _ in FREE_BAGS if n == 'gain_min_contraction_m')
    out = {}
    if not any(x > xm for x in xs):
        out['gain_rise_n_per_pa_m'] = f'no reading past {xm * 1e3:.0f} mm, where x_m can begin'
    if not any(x < 0.0 for x in xs):
        out['stretch_stiffness_n_per_m'] = 'no reading below x = 0 (the muscle stretched)'
    if not obs.records:
        out['natural_frequency_rad_s'] = out['damping_ratio'] = 'no step records'
    return out


def _series(readings: Sequence[tuple[str, float, float, float]]) -> list[list[int]]:
    """Indices of the readings, grouped in series (a run of consecutive readings at one held
    value: x or F, or u for isobaric)."""
    out: list[list[int]] = []
    key = None
    for i, (kind, u, held, _) in enumerate(readings):
        k = (kind, u if kind == 'isobaric' else held)
        if k != key:
            out.append([])
            key = k
        out[-1].append(i)
    return out


def coarse(obs: Observations, most: int = COARSE_READINGS) -> Observations:
    """At most about ``most`` readings: every k-th whole series (a series keeps its own path,
    so its friction loop), and every step record."""
    series = _series(obs.readings)
    if len(obs.readings) <= most or len(series) < 2:
        return obs
    k = math.ceil(len(obs.readings) / most)
    keep = [i for j, s in enumerate(series) if j % k == 0 for i in s]
    return Observations([obs.readings[i] for i in keep], list(obs.records))


def _unfixed(names: list[str], data_jac: np.ndarray, flags: Sequence[str],
             data_fun: np.ndarray | None = None, theta: np.ndarray | None = None,
             span: np.ndarray | None = None) -> list[str]:
    """The parameters the data do not fix (module docstring): those already flagged, those
    the data alone leave a variance above ``UNFIXED_SHARE`` (in z), those whose data-only
    standard error (the residuals' own variance, no prior) exceeds ``UNFIXED_REL`` of their
    value (given ``data_fun``, ``theta`` and ``span``), and then, until none is added, those
    the data fix only together with a flagged one (data-only correlation
    ``JOINT_CORRELATION`` or more)."""
    inv = np.linalg.inv(data_jac.T @ data_jac + DATA_ONLY * np.eye(len(names)))
    share = np.diag(inv)
    sd = np.sqrt(np.maximum(np.diag(inv), 1e-300))
    corr = inv / np.outer(sd, sd)
    out = {i for i, n in enumerate(names) if n in flags or share[i] > UNFIXED_SHARE}
    if data_fun is not None and theta is not None and span is not None:
        err = np.sqrt(share * residual_variance(data_fun, len(names))) * span
        out |= {i for i in range(len(names)) if err[i] > UNFIXED_REL * abs(theta[i])}
    grew = True
    while grew:
        more = {i for i in range(len(names)) if i not in out and any(
            abs(corr[i, j]) >= JOINT_CORRELATION for j in out)}
        out |= more
        grew = bool(more)
    return [n for i, n in enumerate(names) if i in out]


def _law_zoo(obs: Observations, kv: float, l0: float) -> dict[str, float]:
    """RMS (N) of every law of the zoo fitted statically to the isometric readings (the
    extraction's fit: ``analysis.force_models``; at most ``ZOO_READINGS`` of them, evenly
    spread), best first: which law a bag looks like."""
    from pam_bench.analysis.force_models import fit_force_models
    from pam_bench.models.laws.zoo import all_laws
    iso = [(u, x, f) for k, u, x, f in obs.readings if k == 'isometric']
    if len(iso) < 4:
        return {}
    if len(iso) > ZOO_READINGS:
        iso = [iso[i] for i in np.linspace(0, len(iso) - 1, ZOO_READINGS).round().astype(int)]
    u, x, f = (np.array(c, float) for c in zip(*iso, strict=True))
    fits = fit_force_models(kv * u, x, f, l0, tuple(all_laws()))
    return dict(sorted(((m['model'], float(m['rmse_N'])) for m in fits), key=lambda t: t[1]))


def calibrate_bags(obs: Observations, valve: ValveParams | None = None,
                   muscle: MuscleParams | None = None,
                   servo: LoadingServoParams | None = None,
                   max_nfev: int = 60, only: Sequence[str] | None = None,
                   replay: str = 'stepped', workers: Mapper | None = None,
                   start: str = 'data', starts: int = 8, map_starts: Mapper | None = None,
                   law: str | None = None) -> Calibration:
    """Fit ``FREE_BAGS`` (or the names in ``only``) to the observations and say whether the fit
    found the muscle (``fit.calibrate_verdict``).

    The fit starts from values read off the data (``start='data'``,
    ``fit.calibrate_init``; 'defaults': from ``valve`` and ``muscle``, the bench's
    defaults when None), runs a local fit with the readings replayed ``replay`` ('stepped' or
    'static', ``fit.calibrate_replay``), and when the residual is not at the noise level,
    tries ``starts`` more starts spread over the fit intervals (a Latin hypercube; each a local
    fit on the static replay, through ``map_starts``: the cluster), refines the best with the
    replay asked for and keeps whichever fit is better. With ``law`` the muscle is that force
    law of the zoo or a plug-in (``muscle.kind: law``): its parameters, the friction's scale
    and the valve's loop are fitted (``free_of_law``), the law's start from its static fit to
    the isometric readings. A ``muscle`` of kind law (the one the bags declare) is fitted as
    its law, as ``law`` would.

    Returns a ``Calibration`` (its docstring names every field). ``workers``:
    a map-like callable the finite-difference Jacobian's columns are evaluated through
    (scipy's ``least_squares(workers=...)``; ``cluster.layer.map_on`` puts them on the
    cluster).

    Raises:
        ModelError: the observations hold nothing to fit, or the law has no bounds.
        ParameterError: an unknown law (named, with the nearest).
    """
    check_observations(obs)
    t0 = time.perf_counter()
    if law is None and muscle is not None and muscle.kind == 'law':
        law = muscle.law            # the bags' own law: FREE_BAGS are the McKibben law's
    base = Bench(valve or ValveParams(), muscle or MuscleParams(), servo)
    why: dict[str, str] = {}
    the_law: ForceLaw | None = None
    if law is not None:
        from pam_bench.config.settings import LawSettings
        from pam_bench.models.laws.zoo import force_law
        the_law = force_law(law)
        base = Bench(base.valve, dataclasses.replace(base.muscle, kind='law', law=law,
                                                     law_core='compiled'), servo,
                     LawSettings())     # a fit replays the bags many times: compiled
        wanted = free_of_law(the_law)
        initial = {n: 1.0 if n == 'friction_stiffness_scale' else
                   float(getattr(base.valve, n)) for m, n, _, _ in wanted if m != 'law'}
        initial.update({f'{law}.{n}': v for n, v in zip(the_law.params, the_law.start,
                                                          strict=True)})
        est, why = law_start(the_law, obs.readings, obs.records, base.valve, base.muscle)
        initial.update(est)
    else:
        wanted = tuple(f for f in FREE_BAGS if only is None or f[1] in only)
        initial = {n: 1.0 if n == 'friction_stiffness_scale'
                   else float(getattr(base.valve if m == 'valve' else base.muscle, n))
                   for m, n, _, _ in wanted}
        if start == 'data':
            def models_of(values: dict[str, float]) -> tuple[ValveParams, MuscleParams]:
                sub = tuple(f for f in wanted if f[1] in values)
                return _models(np.array([values[f[1]] for f in sub]), base.valve,
                               base.muscle, sub)
            initial, why = initial_values(obs.readings, obs.records, base.valve, base.muscle,
                                          initial, {n: (lo, hi) for _, n, lo, hi in wanted},
                                          models_of)
    unseen = reached(obs)
    held = {n: initial[n] for n in unseen if n in initial}
    base = _bench(np.array(list(held.values())), base, tuple(f for f in wanted if f[1] in held))
    free = tuple(f for f in wanted if f[1] not in held)
    names = [n for _, n, _, _ in free]
    lower = np.array([lo for _, _, lo, _ in free])
    span = np.array([hi - lo for _, _, lo, hi in free])
    z0 = np.clip((np.array([initial[n] for n in names]) - lower) / span, 0.0, 1.0)
    b0 = _bench(lower + z0 * span, base, free)
    left_out = tuple(path_sensitive(obs, b0))
    steps = (law_steps(the_law, free, obs.readings, lower + z0 * span,
                       base.valve.gain_pa_per_v, base.muscle.nominal_length_m)
             if the_law is not None else None)
    problem = _Problem(obs, base, free, left_out, replay, steps)
    pred0 = predict(obs, b0, replay)
    noise = noise_levels(obs.readings, obs.records, servo)
    stop_at = {k: STOP_SHARE * t for k, t in verdict(rms_of(obs, pred0, left_out),
                                                      noise).tolerance.items()}
    evaluations = 0
    z_first = z0
    coarse_profiles: dict[str, Profile] = {}
    theta_coarse = lower + z0 * span
    small = coarse(obs)
    if small is not obs:
        part = dataclasses.replace(problem, obs=small, left_out=tuple(
            path_sensitive(small, b0)))
        sol = _local_fit(part, z0, z0, max_nfev, workers, stop_at=stop_at)
        evaluations += int(sol.nfev)
        z_first = sol.x
        coarse_profiles, lower_z, move = profile(part, sol, z0, PRIOR_WEIGHT, names, [],
                                                 workers)
        evaluations += sum(p.evaluations for p in coarse_profiles.values())
        theta_coarse = lower + sol.x * span
        if lower_z is not None and move is not None:
            z_first, spent = walk(move, lower_z)
            evaluations += spent
    sol = _local_fit(problem, z_first, z0, max_nfev, workers, stop_at=stop_at)
    evaluations += int(sol.nfev)
    best_of: tuple[int, int] = (0, 0)
    first = verdict(rms_by_kind(obs, problem.bench(sol.x), left_out, replay), noise)
    if not first.converged and starts > 0:
        zs = _space_filling(starts, len(names), STARTS_SEED)
        results = list((map_starts or map)(run_start, [(problem, z) for z in zs]))
        costs = np.array([c for _, c in results])
        best = int(np.argmin(costs))
        best_of = (int(np.sum(costs <= costs[best] * (1.0 + BEST_COST_REL) + 1e-9)), starts)
        evaluations += starts * REFINE_NFEV
        mine = problem.data(sol.x)
        for k in np.argsort(costs)[:REFINED_STARTS]:     # the static replay's cost ranks them
            if not np.isfinite(costs[k]):                # only roughly: refine a few stepped
                continue
            refined = _local_fit(problem, results[k][0], results[k][0], max_nfev, workers,
                                 stop_at=stop_at)
            evaluations += int(refined.nfev)
            theirs = problem.data(refined.x)
            if theirs is not None and (mine is None or theirs @ theirs < mine @ mine):
                sol, mine = refined, theirs
    sol, more = _settled(problem, sol, z0, lower, span, max_nfev, workers)
    evaluations += more
    refits = 0
    # what the subset fixes by far, the whole bag fixes too: not moved again (kept_profiles)
    kept = kept_profiles(coarse_profiles, theta_coarse, lower + sol.x * span, names)
    while True:                         # the profile; a lower point it found: fit on from it
        theta = lower + sol.x * span
        summary = fit_summary(names, theta, sol, span, rel_flag=0.05)
        summary['flags'] = _unfixed(names, sol.jac[:-len(names)], summary['flags'],
                                    sol.fun[:-len(names)], theta, span)
        profiles, better, lowest = profile(problem, sol, z0, PRIOR_WEIGHT, names,
                                           summary['flags'], workers, kept)
        evaluations += sum(p.evaluations for p in profiles.values())
        if better is None or refits == PROFILE_REFITS:
            break
        refits += 1
        if lowest is not None:
            better, spent = walk(lowest, better)
            evaluations += spent
        on = _local_fit(problem, better, z0, min(max_nfev, SETTLE_NFEV), workers,
                        stop_at=stop_at)
        evaluations += int(on.nfev)
        if on.cost >= sol.cost:
            break
        kept = kept_profiles(profiles, theta, lower + on.x * span, names)
        sol = on
    loose = [n for n, p in profiles.items() if not p.fixed]
    if loose:
        summary['flags'] = _unfixed(names, sol.jac[:-len(names)], summary['flags'] + loose,
                                    sol.fun[:-len(names)], theta, span)
    summary['report'] = fit_report(summary)
    for n in loose:
        summary['report'][n] = profiles[n].line(summary['values'][n])
    for n, value in held.items():           # not fitted: kept at the start, and flagged
        summary['names'].append(n)
        summary['values'][n] = float(value)
        summary['stderr'][n] = math.nan
        summary['flags'].append(n)
        summary['report'][n] = f'{value:.6g}, held: {unseen[n]}'
    fitted = _bench(theta, base, free)
    rise = 'gain_rise_n_per_pa_m'
    if rise in names and fitted.muscle.gain_rise_n_per_pa_m != summary['values'][rise]:
        summary['values'][rise] = fitted.muscle.gain_rise_n_per_pa_m     # clamped (_bench)
        summary['report'][rise] = (f'{fitted.muscle.gain_rise_n_per_pa_m:.6g}, clamped to '
                                   "the muscle's stability rule (g_r 1 MPa < k_bl)")
    rms_after = rms_by_kind(obs, fitted, left_out, replay)
    zoo = _law_zoo(obs, base.valve.gain_pa_per_v, base.muscle.nominal_length_m)
    hints = _hints(problem, summary['values'], summary['at_bound'])
    if zoo:
        best_law = next(iter(zoo))
        mine_law = law or 'bench_mckibben'
        if best_law != mine_law and zoo[best_law] < 0.5 * zoo.get(mine_law, math.inf):
            hints.append(f'--law {best_law} (its static RMS on the isometric readings '
                         f'{zoo[best_law]:.3g} N against {zoo.get(mine_law, math.inf):.3g} N '
                         f'for {mine_law})')
    verd = verdict(rms_after, noise, hints)
    return Calibration(
        **summary, valve=fitted.valve, muscle=fitted.muscle, laws=fitted.laws,
        rms_before=rms_of(obs, pred0, left_out), rms_after=rms_after, verdict=verd.as_dict(),
        noise=noise, law_zoo=zoo, law=law, start={n: float(initial[n]) for n in names},
        start_from=why, held={n: f'{held[n]:.6g}: {unseen[n]}' for n in held},
        starts={'tried': best_of[1], 'at_best': best_of[0]},
        left_out=[obs.readings[i][:3] for i in left_out], cost=float(sol.cost),
        profile={n: dataclasses.asdict(p) for n, p in profiles.items()},
        evaluations=evaluations, fit_s=time.perf_counter() - t0)


def check_observations(obs: Observations) -> None:
    """Refuse observations that hold nothing to fit, naming what the bags hold instead.

    Raises:
        ModelError: no readings the replay places and no step records (one line).
    """
    if obs.readings or obs.records:
        return
    aside = '; '.join(obs.left_aside)
    raise ModelError('the bags hold no readings calibrate replays and no step records'
                     + (f' ({aside}): record a protocol that settles at each reading, '
                        'isometric_quick, isotonic_quick or campaign_quick, and calibrate its '
                        'bag' if aside else ''))


def bench_of_scene(scene: str | None
                   ) -> tuple[ValveParams | None, MuscleParams | None, LoadingServoParams | None]:
    """(valve, muscle, drive) of the first muscle of scene ``scene`` (a name or a file): the
    bench a lab's bags were recorded on, every value the fit does not free (the muscle's size
    among them); (None, None, None), the bench's defaults, without one.

    Raises:
        ConfigError: an unknown or invalid scene (named), or one without a single-muscle bench.
    """
    if scene is None:
        return None, None, None
    from pam_bench.config.scene import load_scene
    return bench_of_settings(load_scene(scene).settings(), f'scene {scene}')


def bench_of_bags(bags: Sequence[str]
                  ) -> tuple[ValveParams | None, MuscleParams | None, LoadingServoParams | None]:
    """(valve, muscle, drive) the first bag's run description declares (the settings it was
    recorded with: the muscle's size and chamber, its segments, the valve, the drive), the
    bench every value the fit does not free is held at; (None, None, None), the bench's
    defaults, for bags without one (a hand-started recorder's, another recorder's).

    Raises:
        ConfigError: a run description whose settings do not hold a single-muscle bench.
    """
    from pam_bench.bags.baginfo import run_of_bag
    from pam_bench.bags.errors import BagError
    from pam_bench.config.scene import settings_of_params_file
    for bag in bags:
        try:
            params = run_of_bag(bag).get('parameters')
        except BagError:
            continue
        if params:
            st = settings_of_params_file(params, f'{bag}: recorded parameters')
            return bench_of_settings(st, f'{bag}: recorded parameters')
    return None, None, None


def bench_of_settings(st: dict[str, Any], what: str
                      ) -> tuple[ValveParams, MuscleParams, LoadingServoParams]:
    """(valve, muscle, drive) of a scene's node settings (``Scene.settings``): its first
    muscle's bench.

    Raises:
        ConfigError: ``what`` (the scene, named) has no single-muscle bench.
    """
    if not {'valve_1', 'muscle_1', 'loading_servo'} <= set(st):
        from pam_bench.config.errors import ConfigError
        raise ConfigError(f'{what}: calibrate needs a bench with valve_1, muscle_1 and '
                          'loading_servo')
    return st['valve_1'].valve, st['muscle_1'].muscle, st['loading_servo'].servo


def calibrate_bag(job: tuple[str, int, str, str, int, str | None, str | None]
                  ) -> Calibration:
    """One job of ``pam-bench calibrate --each``: (bag folder, largest number of
    evaluations, replay, start, starts, law, scene) -> ``calibrate_bags``' result for that
    bag alone (its starts run one after the other in the job), on the scene's bench, else the
    bench the bag's run description holds.

    Raises:
        BagError: the bag cannot be read.
        ConfigError: the scene cannot be loaded.
    """
    from pam_bench.bags.bagread import read_bags
    bag, max_nfev, replay, start, starts, law, scene = job
    base = bench_of_scene(scene) if scene is not None else bench_of_bags([bag])
    return calibrate_bags(observations_from_bags(read_bags([bag])), *base,
                          max_nfev=max_nfev, replay=replay, start=start, starts=starts,
                          law=law)


def overlay_of(valve: ValveParams, muscle: MuscleParams, laws: Any = None) -> dict[str, Any]:
    """The parameter overlay (``pam-bench run --params``, ``config.scene.apply_overlay``) that
    puts ``valve`` and ``muscle`` (and, for a muscle that holds a force law, that law's
    parameters) on both sides of the bench."""
    m, v = dataclasses.asdict(muscle), dataclasses.asdict(valve)
    sides: dict[str, Any] = {}
    for i in (1, 2):
        sides[f'muscle_{i}'] = {'muscle': dict(m)}
        if muscle.kind == 'law' and laws is not None:
            sides[f'muscle_{i}']['laws'] = {muscle.law: dataclasses.asdict(
                getattr(laws, muscle.law))}
        sides[f'valve_{i}'] = {'valve': dict(v)}
    return {'parameters': sides}
