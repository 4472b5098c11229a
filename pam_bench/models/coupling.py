"""The muscle and whatever holds its end, solved together sub-step by sub-step.

The muscle force depends on where its end is (F = F_m(p, x), ``models.muscle``, with the
braid friction), and the holder (the loading servo, ``models.loading_servo``, or an ideal
angle hold) puts the end where its own dynamics and controller take it under that force. Over
a sub-step d the holder's backward-Euler law gives the end position as a continuous,
non-decreasing function of the force at the end of the sub-step, x_+ = X(F_+), so one scalar
equation fixes the sub-step:

    g(F) = F_m(p_+, X(F)) - F = 0

g is non-increasing in F (the muscle's force falls as its end contracts, the end contracts as
the force grows) with g(0) >= 0 and g(F_hi) <= 0 for F_hi = F_m(p_+, X(0)), so it has one root
in [0, F_hi]. It is found by Newton's method on the tangent g' = -K X'(F) - 1 (K = -dF_m/dx),
started at the previous sub-step's force and kept inside the shrinking bracket (bisection when
a step leaves it; F_hi itself is evaluated only when a step leaves a bracket still open above or
untried at 0): the friction is piecewise linear, so two or three evaluations are usual. The
muscle keeps the friction state of the evaluation at the root, the holder keeps its sub-step
with that force; a holder that only replays the forces (the loading-servo node) reaches the
same state bit for bit.

Settled sub-steps (``SettleParams``, issue 29 item 2): once the force and the end position
stop moving and the valve's pressure over the rest of the exchange stays within a tolerance,
the muscle is held where it is for the remaining sub-steps. The braid friction is rate
independent, so a muscle whose end and pressure do not move keeps its force; the drive still
takes every remaining sub-step with that force (prepare and commit, exactly what the loading
servo node's replay does), so the muscle node, the servo node and the twin keep bit-equal
states. The test after sub-step i >= 1 (of n, i < n - 1), with m = n - 1 - i sub-steps left:

    |F_i - F_(i-1)| m <= force_n,   |x_i - x_(i-1)| m <= contraction_m,
    max_(j > i) |p_j - p_i| <= pressure_pa

(a linear bound on the drift the rest could still carry), and the drive, replayed over the
rest with F_i, must end within ``contraction_m`` of x_i (a drive whose loop still moves, a
force set value not met, fails it: its state is put back, the sub-steps are solved, and the
test waits half the sub-steps left before it tries again). The samples of the held span are
F_i and x_i: the same sub-steps, counts and stamps as the full stepping. The speed and the
readings' error against the 1 ms reference at each tolerance are in BENCHMARKS.md ('Settled
sub-steps: speed against error').

Solving the mechanical coupling inside every sub-step is what lets the devices exchange
messages only once per exchange step (seconds), not once per millisecond: the exchange
step no longer adds a coupling delay to the mechanics (BENCHMARKS.md,
'Exchange step and sub-step against error').
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Protocol

import numpy as np

from pam_bench.models import jit
from pam_bench.models.bench_muscle import BenchMuscle
from pam_bench.models.errors import ModelError
from pam_bench.models.friction import friction_on_backbone
from pam_bench.models.jit import Array, Slots, Values
from pam_bench.models.law_muscle import LawMuscle
from pam_bench.models.loading_servo.drive import LoadingServoModel
from pam_bench.models.loading_servo.substep import (
    CONTRACTION,
    MODE_POSITION,
    NO_PREP,
    DriveRecord,
    drive_commit,
    drive_contraction_and_compliance,
    drive_prepare,
)
from pam_bench.models.muscle import McKibbenRecord, MuscleModel, backbone, effective_pressure
from pam_bench.vocabulary.params import field

__all__ = ['Holder', 'SettleParams', 'SubStepResult', 'solve_substep', 'solve_substeps',
           'substep_grid', 'grid_counts', 'SETTLE_OFF', 'OK']


# --- the coupled solve, compiled (models.jit) ---------------------------------------------
FORCE_TOLERANCE_N = 1.0e-7
MAX_ITERATIONS = 60
OK, BAD_POSITION, BAD_FORCE = 0, 1, 2
"""How a compiled solve ended: every sub-step solved, the drive left its travel, or the
muscle's force is not finite."""


@jit.helper
def mckibben_trial(p: float, x: float, mp: McKibbenRecord, fk: Array, ff0: Array, fmu: Array,
                   z: Array, zt: Array, st: Array) -> tuple[float, float, float]:
    """(F, -dF/dx, friction) of the McKibben muscle at (p, x); the friction elements'
    trial state into zt, st."""
    f_bb, k_bb = backbone(effective_pressure(p, mp), x, mp)
    f, k, ff, _ = friction_on_backbone(f_bb, k_bb, x, mp.hysteresis, mp.ct, fk, ff0, fmu, z,
                                       zt, st)
    return f, k, ff


@jit.helper
def newton_next(f: float, g: float, k: float, dxdf: float, lo: float, hi: float,
                f_hi: float) -> float:
    """The next iterate of the bracketed Newton on g(F) = F_m(p, X(F)) - F (``models.coupling``)
    from F = ``f`` N with g = ``g`` N, the muscle's -dF_m/dx ``k`` N/m and the holder's dX/dF
    ``dxdf`` m/N: the Newton step F + g / (1 + k dX/dF) inside the bracket (lo, hi), else the
    bracket's midpoint once its ends are known, else 0 (while F_hi = F_m(X(0)), ``f_hi``, is
    not tried: negative) or 2 F_hi."""
    nxt = f + g / (1.0 + k * dxdf)
    if lo < nxt < hi:
        return nxt
    if hi < math.inf and (lo > 0.0 or f_hi >= 0.0):
        return 0.5 * (lo + hi)
    if f_hi < 0.0:
        return 0.0
    return 2.0 * f_hi


@jit.helper
def suffix_extremes(values: Values, hi: Slots, lo: Slots) -> None:
    """``hi[j]``, ``lo[j]`` = max, min of ``values[j:]`` for every j (``hi``, ``lo`` start as
    copies of ``values``), shapes (n,)."""
    for j in range(len(values) - 2, -1, -1):
        hi[j] = hi[j] if hi[j] > hi[j + 1] else hi[j + 1]
        lo[j] = lo[j] if lo[j] < lo[j + 1] else lo[j + 1]


@jit.helper
def solve_muscle(trial: Any, tp: Any, hysteresis: float, steps: Array, pressures: Array,
                 f: float, fk: Array, ff0: Array, fmu: Array, z: Array, st: Array,
                 dp: DriveRecord, ds: Array, mode: int, sp: float, out_f: Array, out_x: Array,
                 tol: Array) -> tuple[float, float, int, int, int]:
    """Every sub-step of an exchange (``models.coupling.solve_substeps``) for a muscle on the
    loading drive, the muscle being ``trial(p, x, tp, fk, ff0, fmu, z, zt, st) -> (F N,
    -dF/dx N/m, friction N)`` (``mckibben_trial``; a force law's: ``models.law_kernel``) with
    its parameters ``tp``. ``z``, ``st`` (friction, kept when ``hysteresis``) and ``ds``
    (drive) are updated in place; forces and contractions go to ``out_f``, ``out_x``. ``tol``:
    the settle tolerances (force N, contraction m, pressure Pa; negative: never settle),
    shape (3,). Returns (stiffness -dF/dx N/m and friction N at the end, Newton iterations,
    status: ``OK``, ``BAD_POSITION`` or ``BAD_FORCE``, sub-steps held)."""
    n_el = fk.shape[0]
    n = steps.shape[0]
    zt = z.copy()
    stt = st.copy()
    prep = NO_PREP
    k_last = 0.0
    ff_last = 0.0
    iters = 0
    settle = tol[0] >= 0.0 and n > 2
    saved = ds.copy() if settle else ds          # the arrays are copied only when used
    next_try = 0
    hi_p = pressures.copy() if settle else pressures
    lo_p = pressures.copy() if settle else pressures
    if settle:
        suffix_extremes(pressures, hi_p, lo_p)
    for idx in range(n):
        d = steps[idx]
        p = pressures[idx]
        if dp.dynamics != 0.0:
            prep = drive_prepare(d, dp, ds, mode, sp)
        lo, hi = 0.0, math.inf
        f = f if f > 0.0 else 0.0
        f_hi = -1.0
        it = 1
        while True:
            x, dxdf = drive_contraction_and_compliance(f, dp, ds, mode, sp, prep)
            if not math.isfinite(x):
                return k_last, ff_last, iters, BAD_POSITION, 0
            tf, tk, tff = trial(p, x, tp, fk, ff0, fmu, z, zt, stt)
            if not math.isfinite(tf):
                return k_last, ff_last, iters, BAD_FORCE, 0
            if f == 0.0:
                f_hi = tf
            g = tf - f
            if g >= 0.0:
                lo = f
            else:
                hi = f
            if abs(g) <= FORCE_TOLERANCE_N or hi - lo <= FORCE_TOLERANCE_N or \
                    it >= MAX_ITERATIONS:
                break
            it += 1
            f = newton_next(f, g, tk, dxdf, lo, hi, f_hi)
        if hysteresis != 0.0:
            for i in range(n_el):
                z[i] = zt[i]
                st[i] = stt[i]
        drive_commit(f, dp, ds, mode, sp, prep)
        out_f[idx] = f
        out_x[idx] = x
        k_last, ff_last = tk, tff
        iters += it
        left = n - 1 - idx
        if settle and 0 < idx and left > 0 and idx >= next_try and \
                abs(f - out_f[idx - 1]) * left <= tol[0] and \
                abs(x - out_x[idx - 1]) * left <= tol[1] and \
                max(hi_p[idx + 1] - p, p - lo_p[idx + 1]) <= tol[2]:
            for i in range(ds.shape[0]):
                saved[i] = ds[i]
            for j in range(idx + 1, n):
                if dp.dynamics != 0.0:
                    prep = drive_prepare(steps[j], dp, ds, mode, sp)
                drive_commit(f, dp, ds, mode, sp, prep)
            if abs(ds[CONTRACTION] - x) <= tol[1]:
                for j in range(idx + 1, n):
                    out_f[j] = f
                    out_x[j] = x
                return k_last, ff_last, iters, OK, left
            for i in range(ds.shape[0]):
                ds[i] = saved[i]
            next_try = idx + 1 + left // 2
    return k_last, ff_last, iters, OK, 0


def _solve_mckibben(steps: Array, pressures: Array, f: float, mp: McKibbenRecord, fk: Array,
                    ff0: Array, fmu: Array, z: Array, st: Array, dp: DriveRecord, ds: Array,
                    mode: int, sp: float, out_f: Array, out_x: Array, tol: Array
                    ) -> tuple[float, float, int, int, int]:
    """``solve_muscle`` for a McKibben muscle (``mckibben_trial``, its record ``mp``)."""
    return solve_muscle(mckibben_trial, mp, mp.hysteresis, steps, pressures, f, fk, ff0, fmu,
                        z, st, dp, ds, mode, sp, out_f, out_x, tol)


def _solve_example() -> tuple[Any, ...]:
    muscle = MuscleModel()
    muscle.reset(0.0, 1e5)
    dp, ds = LoadingServoModel().arrays()
    return (np.full(2, 0.005), np.full(2, 1e5), 0.0, *muscle.arrays(), dp, ds, MODE_POSITION,
            0.0, np.zeros(2), np.zeros(2), _NO_SETTLE)


solve_mckibben = jit.kernel('solve_mckibben', _solve_mckibben, _solve_example)


FORCE_TOLERANCE_N = 1.0e-7
MAX_ITERATIONS = 60


class Holder(Protocol):
    """What holds the muscle end over a sub-step (``LoadingServoModel``, ``IdealHold``)."""

    def prepare(self, d: float) -> None:
        """Coefficients of the next sub-step of length d, s."""

    def contraction(self, force_n: float) -> float:
        """End position X(F) for the force at the end of the sub-step, m."""

    def contraction_and_compliance(self, force_n: float) -> tuple[float, float]:
        """(X(F) m, dX/dF m/N) in one evaluation."""

    def commit(self, force_n: float) -> object:
        """Keep the sub-step with that force."""


@dataclasses.dataclass(frozen=True)
class SettleParams:
    """When the rest of an exchange's sub-steps holds the muscle (module docstring)."""

    enabled: bool = field(True, '-', 'hold a settled muscle for the rest of an exchange (off: '
                          'solve every sub-step, the plain reference)')
    force_n: float = field(0.05, 'N', "bound on the force drift the held sub-steps may miss: "
                           "the last sub-step's change times the sub-steps left", 0.0, 100.0)
    contraction_m: float = field(2.0e-6, 'm', 'bound on the end-position drift the held '
                                 'sub-steps may miss (the last change times those left)',
                                 0.0, 1.0e-2)
    pressure_pa: float = field(20.0, 'Pa', "largest move of the valve's pressure over the "
                               'held sub-steps', 0.0, 1.0e5)


SETTLE_OFF = SettleParams(enabled=False)
"""Every sub-step solved (the reference the held spans are tested against)."""


@dataclasses.dataclass
class SubStepResult:
    """Samples of a run of sub-steps: lengths s, forces N, contractions m (shapes (n,)), and
    the muscle's stiffness -dF/dx (N/m), friction (N) and Newton iterations at the end, and
    how many sub-steps held the muscle (``SettleParams``)."""

    steps_s: list[float]
    forces_n: list[float]
    contractions_m: list[float]
    stiffness_n_per_m: float
    friction_n: float
    iterations: int
    held: int = 0


def substep_grid(dt_s: float, period_s: float) -> list[float]:
    """Sub-step lengths of an exchange of ``dt_s`` (s): ``period_s`` from its start, the last
    one shorter when ``dt_s`` is not a multiple (rounded to the nanosecond), shape (n,)."""
    if not (dt_s > 0.0 and period_s > 0.0):
        raise ModelError(f'sub-steps of {dt_s!r} s at a period of {period_s!r} s')
    full, p_ns, rest = grid_counts(dt_s, period_s)
    steps = [p_ns * 1e-9] * full
    if rest:
        steps.append(rest * 1e-9)
    return steps or [dt_s]


def grid_counts(dt_s: float, period_s: float) -> tuple[int, int, int]:
    """``substep_grid`` as counts: (full sub-steps, their length ns, the last one's ns or 0),
    both lengths rounded to the nanosecond (the period to at least 1 ns)."""
    n_ns, p_ns = round(dt_s * 1e9), max(round(period_s * 1e9), 1)
    full, rest = divmod(n_ns, p_ns)
    return full, p_ns, rest


def solve_substep(muscle: BenchMuscle, holder: Holder, d: float, pressure_pa: float,
                  force_guess_n: float) -> tuple[float, float, float, float, int]:
    """One sub-step of length ``d`` (s) ending at gauge pressure ``pressure_pa`` (Pa).

    Returns:
        (F N, x m, stiffness -dF/dx N/m, friction N, iterations); muscle and holder keep it.

    Raises:
        ModelError: the pressure or the holder's position is not finite.
    """
    if not math.isfinite(pressure_pa):
        raise ModelError(f'muscle pressure {pressure_pa!r} is not finite')
    holder.prepare(d)
    # g(0) = F_m(p, X(0)) >= 0 (the muscle never pushes), so [0, inf) brackets the root: the
    # iteration starts at the guess, and the force at X(0), F_hi, is evaluated only when a
    # Newton step leaves the bracket with its lower end 0 untried (or its upper end open);
    # past F_hi, g < 0 (F_m(X(F)) <= F_hi).
    lo, hi = 0.0, math.inf
    f = force_guess_n if force_guess_n > 0.0 else 0.0
    f_hi = -1.0             # not evaluated yet
    it = 1
    while True:
        x, dxdf = holder.contraction_and_compliance(f)
        if not math.isfinite(x):
            raise ModelError(f'holder position {x!r} is not finite')
        trial = muscle.trial(pressure_pa, x)
        if f == 0.0:
            f_hi = trial[0]
        g = trial[0] - f
        if g >= 0.0:
            lo = f
        else:
            hi = f
        if abs(g) <= FORCE_TOLERANCE_N or hi - lo <= FORCE_TOLERANCE_N or it >= MAX_ITERATIONS:
            break
        it += 1
        f = newton_next(f, g, trial[1], dxdf, lo, hi, f_hi)
    muscle.commit(trial)
    holder.commit(f)
    return f, x, trial[1], trial[2], it


def solve_substeps(muscle: BenchMuscle, holder: Holder, steps_s: list[float],
                   pressures_pa: list[float], force_n: float,
                   settle: SettleParams = SETTLE_OFF) -> SubStepResult:
    """Every sub-step of an exchange: lengths (s) and the pressure at the end of each (Pa),
    starting from the force ``force_n`` (N) of the last sub-step; a settled muscle is held for
    the rest (``settle``, module docstring).

    Raises:
        ModelError: the lists differ in length or a value is not finite.
    """
    if len(steps_s) != len(pressures_pa) or not len(steps_s):
        raise ModelError(f'{len(pressures_pa)} pressures for {len(steps_s)} sub-steps')
    if type(holder) is LoadingServoModel and jit.wanted(len(steps_s)):
        if type(muscle) is MuscleModel:
            return _solve_compiled(muscle, holder, steps_s, pressures_pa, force_n, settle,
                                   solve_mckibben)
        if type(muscle) is LawMuscle:
            kernel = muscle.kernel()
            if kernel is not None:
                return _solve_compiled(muscle, holder, steps_s, pressures_pa, force_n, settle,
                                       kernel)
    forces: list[float] = []
    xs: list[float] = []
    k = ff = 0.0
    iters = 0
    f = force_n
    n = len(steps_s)
    hi_p, lo_p = (_suffix_extremes(pressures_pa) if settle.enabled and n > 2
                  else ([], []))
    next_try = 0
    for i, (d, p) in enumerate(zip(steps_s, pressures_pa, strict=True)):
        f, x, k, ff, it = solve_substep(muscle, holder, d, p, f)
        forces.append(f)
        xs.append(x)
        iters += it
        left = n - 1 - i
        if hi_p and 0 < i and left > 0 and i >= next_try and \
                abs(f - forces[i - 1]) * left <= settle.force_n and \
                abs(x - xs[i - 1]) * left <= settle.contraction_m and \
                max(hi_p[i + 1] - p, p - lo_p[i + 1]) <= settle.pressure_pa:
            drive = holder if isinstance(holder, LoadingServoModel) else None
            saved = drive.arrays()[1] if drive is not None else None
            for d_rest in steps_s[i + 1:]:
                holder.prepare(d_rest)
                holder.commit(f)
            end = drive.contraction_m if drive is not None else x   # IdealHold: x_0 + F/k_b
            if abs(end - x) <= settle.contraction_m:
                forces.extend([f] * left)
                xs.extend([x] * left)
                return SubStepResult(list(steps_s), forces, xs, k, ff, iters, left)
            if drive is not None and saved is not None:
                drive.set_state(saved)
            next_try = i + 1 + left // 2
    return SubStepResult(list(steps_s), forces, xs, k, ff, iters)


def _suffix_extremes(values: list[float]) -> tuple[list[float], list[float]]:
    """(max, min) of ``values[j:]`` for every j, shapes (n,) (``suffix_extremes``)."""
    hi, lo = list(values), list(values)
    suffix_extremes(values, hi, lo)
    return hi, lo


def _solve_compiled(muscle: MuscleModel | LawMuscle, drive: LoadingServoModel, steps_s: Any,
                    pressures_pa: Any, force_n: float, settle: SettleParams,
                    kernel: Any) -> SubStepResult:
    """``solve_substeps`` on the compiled core (``models.jit``; ``kernel``: the muscle's
    compiled solve): the reference's results (bit-equal for the McKibben muscle), the
    muscle's friction and the drive's state kept as the reference keeps them."""
    steps = np.asarray(steps_s, dtype=float)
    pressures = np.asarray(pressures_pa, dtype=float)
    if not np.isfinite(pressures).all():
        bad = pressures[~np.isfinite(pressures)][0]
        raise ModelError(f'muscle pressure {bad!r} is not finite')
    if not (np.isfinite(steps).all() and (steps > 0.0).all()):
        bad = steps[~(np.isfinite(steps) & (steps > 0.0))][0]
        raise ModelError(f'loading servo sub-step {bad!r} s is not finite and positive')
    mp, fk, ff0, fmu, z, st = muscle.arrays()
    dp, ds = drive.arrays()
    n = len(steps)
    out_f, out_x = np.empty(n), np.empty(n)
    tol = (np.array([settle.force_n, settle.contraction_m, settle.pressure_pa])
           if settle.enabled else _NO_SETTLE)
    k, ff, iters, status, held = kernel(
        steps, pressures, float(force_n), mp, fk, ff0, fmu, z, st, dp, ds, int(drive.mode),
        float(drive.setpoint), out_f, out_x, tol)
    if status == BAD_FORCE:
        raise ModelError(f'the muscle force is not finite at p = {pressures[-1]!r} Pa')
    if status != OK:
        raise ModelError('holder position is not finite')
    muscle.friction.set_state(z, st)
    drive.set_state(ds)
    return SubStepResult(list(steps_s), out_f.tolist(), out_x.tolist(), k, ff, iters, held)


_NO_SETTLE = np.full(3, -1.0)
"""Tolerances the compiled solve never meets (every sub-step solved)."""
