"""A series of held set values on the single-muscle bench, as one compiled call.

``SingleMuscleBench`` takes an exchange at a time in Python (``twin.bench``): the valve's ZOH
samples (``models.valve``), the coupled muscle-drive solve (``models.coupling``), the drive's
command one exchange late, the valve's request for short exchanges while its pressure is in
transient. A bag calibration replays thousands of readings that way (``fit.calibrate_replay``):
each reading holds a voltage and a load set value through phases of given duration, exchange
step and sub-step, and the Python around each exchange cost as much as the physics.
``run_holds`` does the same exchanges inside one numba function (``hold_series``), calling the
same functions: ``models.lti.zoh_2x2_floats`` and ``_zoh_run`` for the valve,
``models.coupling`` for the solve, ``models.valve.transient_request`` and ``volume_report``
for the exchange steps, ``models.muscle.braid_volume`` for the chamber. Per exchange of h
seconds at sub-step T (``SingleMuscleBench.step``, ``run``):

    sub-steps      full x T_ns plus the rest, both rounded to 1 ns    (coupling.grid_counts)
    valve          p_j = ZOH of the loop at w(V_k-1) over each sub-step, clamped to [0, p_max]
    muscle, drive  F_j, x_j = the coupled solve over the sub-steps (solve_mckibben)
    command        a new load mode and set value act after the exchange they are sent in
    next step      h = min(phase step, the valve's request), the phase's end not passed

It runs for a McKibben muscle (``models.muscle.MuscleModel``), a valve of order 2 with the ZOH
scheme (004's; a first-order lag's ZOH needs ``expm`` over most sub-steps) and the compiled
core loaded; anything else, or a value that a Python step would refuse (the solve's status),
returns None and the caller steps in Python, which says why. The
sensors are not stepped (a replay reads the true force and pulley angle). The results equal the
Python steps' to rounding (the ZOH cache's key rounds w to 1e-9 rad/s; test/twin).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from pam_bench.models import jit
from pam_bench.models.coupling import OK, _solve_mckibben, grid_counts
from pam_bench.models.jit import Array
from pam_bench.models.loading_servo import LoadMode
from pam_bench.models.loading_servo.substep import (
    FORCE,
    INTEGRAL,
    PHI,
    DriveRecord,
    drive_play,
)
from pam_bench.models.lti import _zoh_run, zoh_2x2_floats
from pam_bench.models.muscle import McKibbenRecord, MuscleModel, braid_volume
from pam_bench.models.valve import (
    loop_entries,
    scaled_frequency,
    steady_target,
    transient_request,
    volume_report,
)
from pam_bench.protocol.sequencer import COMMAND_STEP_S

__all__ = ['run_holds', 'run_steps', 'hold_series', 'step_series']

# the bench's scalars in one array (``hold_series``' ``sv``)
(T, U, U_APPLIED, P, F, X, VOLUME, REQUEST, EV_HAS_LAST, EV_T0, EV_V0, EV_COMMAND_T,
 EV_CHANGE, EV_SPAN, S0, S1, MODE, SETPOINT, EXCHANGES, SUBSTEPS) = range(20)
SV_SIZE = 20
# the valve's parameters (``vp``)
(V_ORDER, V_GAIN, V_UMAX, V_PMAX, V_W0, V_ZETA, V_TAU, V_SCALING, V_LINE, V_REF,
 V_TRANSIENT, V_RATE_TOL, V_SETTLED) = range(13)
VP_SIZE = 13
BAD = 1
"""``hold_series`` status: a step the Python bench must take (and say why)."""


def _valve_w(vp: Array, volume: float) -> float:
    """The loop's frequency at the chamber volume (``ValveModel.natural_frequency``)."""
    if vp[V_SCALING] > 0.0:
        return scaled_frequency(vp[V_W0], vp[V_LINE], vp[V_REF], volume)
    return vp[V_W0]


def _exchange(h: float, period: float, sv: Array, vp: Array, mp: McKibbenRecord, fk: Array,
              ff0: Array, fmu: Array, z: Array, st: Array, dp: DriveRecord, ds: Array,
              pending_mode: float, pending_sp: float, steps: Array, pressures: Array,
              out_f: Array, out_x: Array, tol: Array, thread_m: float, turns: float,
              length_m: float) -> int:
    """One ``SingleMuscleBench.step(h)`` at sub-step ``period`` (s); a pending command
    (``pending_mode`` >= 0) acts after it. Returns OK or ``BAD``."""
    if not math.isnan(sv[U_APPLIED]) and sv[U] != sv[U_APPLIED]:   # command_changed
        sv[EV_COMMAND_T] = sv[T]
        sv[EV_SPAN] = 0.0
    sv[U_APPLIED] = sv[U]
    if sv[EV_HAS_LAST] > 0.0 and sv[VOLUME] > 0.0:             # evidence.volume
        change, span = volume_report(sv[EV_T0], sv[EV_V0], sv[EV_COMMAND_T], sv[T], sv[VOLUME])
        sv[EV_CHANGE] = change
        sv[EV_SPAN] = span
    sv[EV_HAS_LAST] = 1.0
    sv[EV_T0] = sv[T]
    sv[EV_V0] = sv[VOLUME]
    full, p_ns, rest = grid_counts(h, min(period, h))
    n = full + (1 if rest else 0)
    if n == 0:
        return BAD                                            # a step below 1 ns
    if n > steps.shape[0]:
        return BAD
    d_full = p_ns * 1e-9
    for i in range(full):
        steps[i] = d_full
    if rest:
        steps[full] = rest * 1e-9
    # the valve (ValveModel.samples, order 1 or 2, ZOH)
    target = steady_target(vp[V_GAIN], vp[V_UMAX], sv[U])
    e00, e01, e10, e11, e0, e1 = loop_entries(vp[V_ORDER], vp[V_TAU], vp[V_ZETA],
                                              _valve_w(vp, sv[VOLUME]))
    s0, s1 = sv[S0], sv[S1]
    i = 0
    while i < n:
        d = steps[i]
        m = full if i == 0 and full > 0 else 1
        zz = zoh_2x2_floats(e00, e01, e10, e11, e0, e1, d)
        if zz is None:
            return BAD                                        # expm: the Python bench's
        a00, a01, a10, a11, b0, b1 = zz
        s0, s1 = _zoh_run(s0, s1, a00, a01, a10, a11, b0 * target, b1 * target, m, vp[V_PMAX],
                         pressures, i)
        i += m
    sv[S0] = s0
    sv[S1] = s1
    # the muscle and the drive
    status = _solve_mckibben(steps[:n], pressures[:n], sv[F], mp, fk, ff0, fmu, z, st, dp, ds,
                             int(sv[MODE]), sv[SETPOINT], out_f[:n], out_x[:n], tol)[3]
    if status != OK:
        return BAD
    if pending_mode >= 0.0:                                   # servo.command
        if pending_mode != sv[MODE]:
            ds[INTEGRAL] = 0.0
        sv[MODE] = pending_mode
        sv[SETPOINT] = pending_sp
    sv[P] = pressures[n - 1]
    sv[F] = out_f[n - 1]
    sv[X] = out_x[n - 1]
    if vp[V_ORDER] == 0.0:
        sv[REQUEST] = 0.0
    else:
        w_ref = vp[V_W0] if vp[V_ORDER] == 2.0 else 1.0 / vp[V_TAU]
        sv[REQUEST] = transient_request(sv[EV_SPAN], sv[EV_CHANGE], s0, s1, target, w_ref,
                                        vp[V_TRANSIENT], vp[V_RATE_TOL], vp[V_SETTLED])
    sv[VOLUME] = braid_volume(sv[X], length_m, thread_m, turns)
    sv[T] = sv[T] + h
    sv[EXCHANGES] += 1.0
    sv[SUBSTEPS] += n
    return OK


def hold_series(holds: Array, phases: Array, position: Array, sv: Array, vp: Array,
                mp: McKibbenRecord, fk: Array, ff0: Array, fmu: Array, z: Array, st: Array,
                dp: DriveRecord, ds: Array, thread_m: float, turns: float, length_m: float,
                command_step_s: float, max_substeps: int, out: Array) -> int:
    """Every hold in turn: ``holds`` (K, 3) rows of (voltage V, load mode, set value N or m),
    each through the ``phases`` (P, 3) rows of (duration s, longest exchange s, sub-step s),
    as ``SingleMuscleBench.command_valve``, ``command_load`` and ``run`` do. ``out[k]``: the
    force (N) after hold k where ``position[k]``, else the pulley's travel (angle x r, m).
    The bench's state is ``sv`` (indexed by ``T`` ...), the friction's ``z``, ``st`` and the
    drive's ``ds``, all updated in place. Returns OK, or ``BAD`` at the first exchange the
    Python bench must take."""
    steps = np.empty(max_substeps)
    pressures = np.empty(max_substeps)
    out_f = np.empty(max_substeps)
    out_x = np.empty(max_substeps)
    tol = np.full(3, -1.0)                                    # every sub-step solved
    for k in range(holds.shape[0]):
        sv[U] = holds[k, 0]
        pending_mode, pending_sp = holds[k, 1], holds[k, 2]
        for ph in range(phases.shape[0]):
            duration, h_s, period = phases[ph, 0], phases[ph, 1], phases[ph, 2]
            t_end = sv[T] + duration
            first = True
            if pending_mode >= 0.0:                           # run(): first_s
                status = _exchange(min(command_step_s, duration), period, sv, vp, mp, fk, ff0,
                                   fmu, z, st, dp, ds, pending_mode, pending_sp, steps,
                                   pressures, out_f, out_x, tol, thread_m, turns, length_m)
                if status != OK:
                    return status
                pending_mode = -1.0
                first = False
            while first or sv[T] < t_end - 1e-9:
                first = False
                h = h_s
                if sv[REQUEST] > 0.0:
                    h = min(h, sv[REQUEST])
                status = _exchange(min(h, max(t_end - sv[T], 1e-9)), period, sv, vp, mp, fk,
                                   ff0, fmu, z, st, dp, ds, -1.0, 0.0, steps, pressures,
                                   out_f, out_x, tol, thread_m, turns, length_m)
                if status != OK:
                    return status
        if position[k]:
            out[k] = sv[F]
        else:
            out[k] = (ds[PHI] + drive_play(ds[FORCE], dp)) * dp.r
    return OK


def step_series(n: int, h_s: float, period_s: float, sv: Array, vp: Array,
                mp: McKibbenRecord, fk: Array, ff0: Array, fmu: Array, z: Array, st: Array,
                dp: DriveRecord, ds: Array, thread_m: float, turns: float, length_m: float,
                max_substeps: int, out: Array) -> int:
    """``n`` exchanges of ``h_s`` at sub-step ``period_s`` (s), as ``SingleMuscleBench.step``
    in a loop; ``out[i]``: the force after exchange i, N. The rest as ``hold_series``."""
    steps = np.empty(max_substeps)
    pressures = np.empty(max_substeps)
    out_f = np.empty(max_substeps)
    out_x = np.empty(max_substeps)
    tol = np.full(3, -1.0)
    for i in range(n):
        status = _exchange(h_s, period_s, sv, vp, mp, fk, ff0, fmu, z, st, dp, ds, -1.0, 0.0,
                           steps, pressures, out_f, out_x, tol, thread_m, turns, length_m)
        if status != OK:
            return status
        out[i] = sv[F]
    return OK


def _compiled(fn: Any, example: Any) -> Any:
    """``fn`` compiled, called once with ``example()`` the first time (None where numba is not
    loaded or cannot compile it)."""
    if not jit.enabled():
        return None
    if fn not in _DONE:
        _DONE[fn] = jit.compile_function(fn, example())[0]
    return _DONE[fn]


_DONE: dict[Any, Any] = {}


def _example_bench() -> tuple[Any, ...]:
    """(sv, vp, mp, fk, ff0, fmu, z, st, dp, ds, thread, turns, length) of a new bench."""
    from pam_bench.models.loading_servo import LoadingServoModel
    from pam_bench.models.valve import ValveParams
    muscle = MuscleModel()
    muscle.reset(0.0, 0.0)
    dp, ds = LoadingServoModel().arrays()
    return (_state_of_new(), _valve_array(ValveParams()), *muscle.arrays(), dp, ds, 0.38, 3.0,
            0.3)


def _hold_example() -> tuple[Any, ...]:
    return (np.array([[1.0, 2.0, 0.0]]), np.array([[0.01, 0.01, 0.005]]), np.array([True]),
            *_example_bench(), COMMAND_STEP_S, 16, np.zeros(1))


def _step_example() -> tuple[Any, ...]:
    return (2, 0.01, 0.005, *_example_bench(), 16, np.zeros(2))


def _state_of_new() -> Array:
    sv = np.zeros(SV_SIZE)
    sv[U_APPLIED] = math.nan
    sv[EV_COMMAND_T] = -math.inf
    sv[MODE] = 1.0
    return sv


def _valve_array(p: Any) -> Array:
    """The valve's parameters as ``vp`` (``ValveParams``)."""
    vp = np.zeros(VP_SIZE)
    vp[V_ORDER] = p.order
    vp[V_GAIN] = p.gain_pa_per_v
    vp[V_UMAX] = p.voltage_max_v
    vp[V_PMAX] = p.pressure_max_pa
    vp[V_W0] = p.natural_frequency_rad_s
    vp[V_ZETA] = p.damping_ratio
    vp[V_TAU] = p.time_constant_s
    vp[V_SCALING] = 1.0 if p.volume_scaling else 0.0
    vp[V_LINE] = p.line_volume_m3
    vp[V_REF] = p.reference_volume_m3
    vp[V_TRANSIENT] = p.transient_step_s
    vp[V_RATE_TOL] = p.volume_rate_tolerance_per_s
    vp[V_SETTLED] = p.settled_tolerance_pa
    return vp


def run_holds(twin: Any, holds: Sequence[tuple[float, LoadMode, float]],
              phases: Sequence[tuple[float, float, float]], position: Sequence[bool]
              ) -> np.ndarray | None:
    """``hold_series`` on a ``twin.bench.SingleMuscleBench``: every hold (voltage V, load mode,
    set value) through the phases (duration s, longest exchange s, sub-step s); the twin is
    left where the Python steps would leave it (its sensors aside). Returns the value after
    each hold (the force N where ``position``, else the pulley's travel m), or None (the twin
    untouched) where the compiled path does not apply (module docstring)."""
    if not holds:
        return np.zeros(0)
    hold_arr = np.array([(float(u), float(int(LoadMode(m))), float(v)) for u, m, v in holds])
    phase_arr = np.array(phases, dtype=float)
    if not (np.isfinite(hold_arr).all() and np.isfinite(phase_arr).all()
            and (phase_arr > 0.0).all()):
        return None
    longest = max(max(h for _, h, _ in phases), COMMAND_STEP_S)
    out = np.empty(len(holds))
    ok = _run(twin, hold_series, _hold_example, lambda bench, max_sub: (
        hold_arr, phase_arr, np.array(position, dtype=np.bool_), *bench, COMMAND_STEP_S,
        max_sub, out), longest / min(s for _, _, s in phases))
    return out if ok else None


def run_steps(twin: Any, n: int, h_s: float, sub_step_s: float) -> np.ndarray | None:
    """``step_series`` on a ``SingleMuscleBench``: ``n`` exchanges of ``h_s`` at sub-step
    ``sub_step_s`` (s), as ``twin.step(h_s)`` n times with ``twin.sub_step_s`` at that; the
    force after each (N), or None (the twin untouched) as ``run_holds``."""
    if not (n >= 0 and math.isfinite(h_s) and h_s > 0.0 and math.isfinite(sub_step_s)
            and sub_step_s > 0.0):
        return None
    out = np.empty(n)
    ok = _run(twin, step_series, _step_example, lambda bench, max_sub: (
        n, h_s, sub_step_s, *bench, max_sub, out), h_s / min(sub_step_s, h_s))
    return out if ok else None


def _run(twin: Any, fn: Any, example: Any, args: Any, most_substeps: float) -> bool:
    """Call the compiled ``fn`` with ``args(bench arrays, max sub-steps)`` on the twin's state
    and put the state it leaves back into the twin; False (the twin untouched) where the
    compiled path does not apply (module docstring) or a step needs the Python bench."""
    if (type(twin.muscle) is not MuscleModel or twin.valve.p.order != 2
            or twin.valve.p.scheme != 'zoh' or twin.settle.enabled
            or twin._pending is not None or not math.isfinite(twin.u)):
        return False
    compiled = _compiled(fn, example)
    if compiled is None:
        return False
    sv = _state_of(twin)
    mp, fk, ff0, fmu, z, st = twin.muscle.arrays()
    dp, ds = twin.servo.arrays()
    bench = (sv, _valve_array(twin.valve.p), mp, fk, ff0, fmu, z, st, dp, ds,
             float(twin.muscle._thread_m), float(twin.muscle._turns),
             float(twin.muscle.p.nominal_length_m))
    if compiled(*args(bench, int(max(math.ceil(most_substeps) + 2, 16)))) != OK:
        return False
    _put_back(twin, sv, z, st, ds)
    return True


def _state_of(twin: Any) -> Array:
    """The twin's scalars as ``sv``."""
    sv = np.zeros(SV_SIZE)
    ev = twin.evidence
    sv[T], sv[U], sv[P], sv[F], sv[X] = twin.t, twin.u, twin.p, twin.f, twin.x
    sv[U_APPLIED] = math.nan if twin._u_applied is None else twin._u_applied
    sv[VOLUME], sv[REQUEST] = twin.volume, twin._request
    if ev._last is not None:
        sv[EV_HAS_LAST] = 1.0
        sv[EV_T0], sv[EV_V0] = ev._last
    sv[EV_COMMAND_T], sv[EV_CHANGE], sv[EV_SPAN] = ev._command_t, ev.change_rel, ev.span_s
    sv[S0], sv[S1] = float(twin.valve.state[0]), float(twin.valve.state[1])
    sv[MODE], sv[SETPOINT] = float(int(twin.servo.mode)), float(twin.servo.setpoint)
    return sv


def _put_back(twin: Any, sv: Array, z: Array, st: Array, ds: Array) -> None:
    """The state ``hold_series`` left, into the twin and its models."""
    twin.t, twin.u, twin.p, twin.f, twin.x = (float(sv[T]), float(sv[U]), float(sv[P]),
                                              float(sv[F]), float(sv[X]))
    twin._u_applied = float(sv[U_APPLIED])
    twin.volume, twin._request = float(sv[VOLUME]), float(sv[REQUEST])
    ev = twin.evidence
    if sv[EV_HAS_LAST] > 0.0:
        ev._last = (float(sv[EV_T0]), float(sv[EV_V0]))
    ev._command_t = float(sv[EV_COMMAND_T])
    ev.change_rel, ev.span_s = float(sv[EV_CHANGE]), float(sv[EV_SPAN])
    twin.valve.state = np.array([sv[S0], sv[S1]])
    twin.servo.set_state(ds)
    twin.servo.mode, twin.servo.setpoint = LoadMode(int(sv[MODE])), float(sv[SETPOINT])
    twin.muscle.friction.set_state(z, st)
    twin.steps += int(sv[EXCHANGES])
    twin.substeps += int(sv[SUBSTEPS])
