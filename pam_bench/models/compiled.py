"""The physics' hot loops compiled with numba: the reference's equations, in machine code.

What is compiled (``@njit(cache=True)``, plain floats and arrays in and out):

- the valve's exact ZOH over a run of equal sub-steps (``models.valve``, 004 section 2.1:
  s_(k+1) = A_d s_k + B_d p_ss, the gauge pressure clamped to [0, p_max]);
- the McKibben muscle's backbone F_bb(p, x) and stiffness (``models.muscle``: g(x) e(p) -
  k_bl x + k_s (-x)^+ - k_l (x - x_l)^+, e(p) the softplus contact band) with the Maxwell-slip
  braid friction on s = x + c_t F_bb^+ (``models.friction``, 004 section 2.2);
- the loading drive's backward-Euler sub-step law X(F) and its commit
  (``models.loading_servo.drive``: force, position and off modes, the ideal holder of
  ``dynamics: false``);
- the coupled sub-step solve g(F) = F_m(p_+, X(F)) - F = 0 by bracketed Newton
  (``models.coupling``), sub-step after sub-step, with its settle test (a settled muscle held
  for the rest of the exchange, the drive replayed).

Every function repeats the reference's floating-point operations in the reference's order, so
the results are bit-equal (``test/models/test_compiled.py`` checks tables, the friction's turning
points, the braid lock-up, the valve's clamp and whole protocol runs). The pure-Python modules
stay the reference; ``PAM_BENCH_CORE=python`` (or ``use('python')``) runs them instead, and
000's straight-fibre muscle always does (its law interpolates 000's printed graph).

The kernels are written once, as typed Python over named records (``McKibbenRecord``,
``DriveRecord``, ``Prep``): numba compiles the three entry points (``zoh_run``,
``solve_mckibben``, ``replay_drive``) into ``_COMPILED`` and the helpers into them
(``register_jitable``); nothing in the module is replaced. Until they are loaded, an entry point
runs the same function interpreted.

The kernels load in a background thread the first time an exchange brings ``LOAD_AT`` sub-steps
or more (``wanted``): numba's import and its cache cost about half a second, which a short
run with few sub-steps per exchange (the demo, a servo scene) never wins back. Until they are
in, the reference runs, bit-equal. The compiled cache goes to
``NUMBA_CACHE_DIR`` when set, else to ``$XDG_CACHE_HOME/pam_bench/numba`` (``~/.cache``):
a wheel or a colcon ``install/`` is read-only, and numba's default (``__pycache__`` beside
the module) is not writable there.
"""

from __future__ import annotations

import math
import os
import pathlib
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, NamedTuple, cast

if TYPE_CHECKING:
    from collections.abc import Sequence

    import numpy as np

    Array = np.ndarray
    Values = np.ndarray | Sequence[float]
    """Read: an array (compiled) or a sequence (the objects' interpreted calls)."""
    Slots = np.ndarray | list[Any]
    """Written in place: an array or a list."""
else:
    Array = Values = Slots = Any

__all__ = ['available', 'enabled', 'core', 'wanted', 'LOAD_AT', 'use', 'start_loading',
           'cache_dir', 'zoh_run', 'solve_mckibben', 'replay_drive', 'McKibbenRecord',
           'DriveRecord', 'Prep', 'PHI', 'W', 'INTEGRAL', 'FORCE', 'ENCODER', 'CONTRACTION',
           'TORQUE', 'SATURATED', 'STATE_SIZE', 'softplus', 'backbone', 'MODE_OFF', 'MODE_FORCE',
           'MODE_POSITION', 'OK', 'BAD_POSITION', 'warm_up']


def cache_dir() -> pathlib.Path:
    """Where numba keeps the compiled functions (module docstring)."""
    env = os.environ.get('NUMBA_CACHE_DIR')
    if env:
        return pathlib.Path(env)
    base = os.environ.get('XDG_CACHE_HOME') or str(pathlib.Path.home() / '.cache')
    return pathlib.Path(base) / 'pam_bench' / 'numba'


os.environ.setdefault('NUMBA_CACHE_DIR', str(cache_dir()))

_WANTED = os.environ.get('PAM_BENCH_CORE', 'compiled') != 'python'
_READY = threading.Event()           # the kernels are compiled (or loaded from the cache)
_FAILED: list[str] = []              # why they could not be
_LOCK = threading.Lock()
_LOADER: threading.Thread | None = None


def available() -> bool:
    """Whether the compiled kernels load here (waits for them)."""
    _load()
    return _READY.is_set()


def enabled() -> bool:
    """Whether the compiled core runs now: wanted and loaded. Until the kernels have loaded
    (``start_loading``: numba's import and its cache take about half a second) the reference
    runs; the two are bit-equal, so a run does not depend on when the switch happens."""
    return _WANTED and _READY.is_set()


def core() -> str:
    """The core asked for, loaded or not: 'compiled' (the default) or 'python' (``use``, or
    ``PAM_BENCH_CORE=python``). ``enabled`` says whether it runs yet: what a caller that
    switches the core for a while must restore is this, not ``enabled``, or a switch made
    before the kernels have loaded would leave the process on the reference for good."""
    return 'compiled' if _WANTED else 'python'


def use(core: str) -> None:
    """Run the 'compiled' core (waiting for it to load) or the 'python' reference from now on
    (tests compare them).

    Raises:
        ValueError: an unknown core, or 'compiled' where numba does not load.
    """
    global _WANTED
    if core not in ('compiled', 'python'):
        raise ValueError(f"core {core!r}: 'compiled' or 'python'")
    if core == 'compiled':
        _load()
        if not _READY.is_set():
            raise ValueError(f'the compiled core does not load: {_FAILED[0]}')
    _WANTED = core == 'compiled'


LOAD_AT = 32
"""Sub-steps in one call that make the compiled core worth loading (module docstring)."""
FEW = 4
"""Below this many sub-steps a call runs on the reference: packing the arrays costs more than
the few sub-steps (a 1 ms servo exchange has one)."""


def wanted(n: int) -> bool:
    """Whether to run a call of ``n`` sub-steps on the compiled core: yes once it is loaded;
    a call of ``LOAD_AT`` or more starts loading it."""
    if _READY.is_set():
        return _WANTED and n >= FEW
    if n >= LOAD_AT:
        start_loading()
    return False


def start_loading() -> None:
    """Load the kernels in a background thread (a run starts on the reference meanwhile)."""
    global _LOADER
    with _LOCK:
        if _LOADER is None and _WANTED:
            _LOADER = threading.Thread(target=_load, name='pam_bench-compiled-core',
                                       daemon=True)
            _LOADER.start()


# --- what the kernels take ------------------------------------------------------------------
class McKibbenRecord(NamedTuple):
    """The McKibben muscle's parameters by name (``models.muscle``; built by
    ``McKibbenMuscle.record``): gains N/Pa (g0, gm), the gain minimum's contraction xm m, the
    exponent n, the rise gr N/(Pa m), the contact band (threshold pth Pa, width w Pa, offset
    e0 Pa), the stiffnesses kbl, ks, kl N/m, the lock-up contraction xl m, whether the braid
    has friction (hysteresis, 1 or 0) and its slip compliance ct m/N."""

    g0: float
    gm: float
    xm: float
    n: float
    gr: float
    pth: float
    w: float
    e0: float
    kbl: float
    ks: float
    kl: float
    xl: float
    hysteresis: float
    ct: float


class DriveRecord(NamedTuple):
    """The loading drive's parameters by name (``models.loading_servo``; built by
    ``LoadingServoModel.record``): pulley radius r m, inertia j kg m^2, damping c N m s/rad,
    torque limit tau_max N m, half the backlash rad, the encoder's count rad, the backlash
    force N, belt stiffness N/m, travel end stops m, speed limit rad/s, the force loop's gains
    and integral band, the position loop's gains, the force limit N, and whether the drive's
    mechanics are simulated (dynamics, 1) or the ideal holder stands in (0)."""

    r: float
    j: float
    c: float
    tau_max: float
    half_play: float
    count_rad: float
    backlash_force_n: float
    belt_stiffness: float
    travel_min: float
    travel_max: float
    speed_limit: float
    force_kp: float
    force_ki: float
    force_kd: float
    force_band: float
    position_kp: float
    position_ki: float
    position_kd: float
    force_limit: float
    dynamics: float


class Prep(NamedTuple):
    """One sub-step of the drive prepared (``_prepare``): its length d s and the damping
    divisor den, the torque t0 + t1 F and the integral i0 + i1 F as functions of the end force
    F, the integral's limit and gain, and the position loop's rate w_pos when it fixes one
    (has_w_pos 1)."""

    d: float
    den: float
    t0: float
    t1: float
    i0: float
    i1: float
    i_lim: float
    ki: float
    w_pos: float
    has_w_pos: float


NO_PREP = Prep(0.0, 1.0, 0.0, 0.0, 0.0, 0.0, math.inf, 0.0, 0.0, 0.0)
"""The ideal holder's (no sub-step is prepared for it)."""

PHI, W, INTEGRAL, FORCE, ENCODER, CONTRACTION, TORQUE, SATURATED = range(8)
"""Where the drive's state sits in the state array the kernels update in place: gear output
angle rad, rate rad/s, position-loop integral, force N, encoder angle rad, contraction m,
torque N m, saturated (1 or 0) (``LoadingServoModel.state_array``)."""
STATE_SIZE = 8
MODE_OFF, MODE_FORCE, MODE_POSITION = 0, 1, 2
OK, BAD_POSITION = 0, 1
FORCE_TOLERANCE_N = 1.0e-7
MAX_ITERATIONS = 60
IDEAL_FORCE_COMPLIANCE_M_PER_N = 1.0e-3


# --- valve ---------------------------------------------------------------------------------
def _zoh_run(s0: float, s1: float, a00: float, a01: float, a10: float, a11: float, b0: float,
             b1: float, n: int, p_max: float, out: Array, start: int) -> tuple[float, float]:
    """``n`` equal ZOH sub-steps from the state (s0 Pa, s1 Pa/s) with the (already scaled)
    input terms b0, b1; the clamped gauge pressure of each into ``out[start:start + n]``.
    Returns the state after them."""
    for i in range(n):
        s0, s1 = a00 * s0 + a01 * s1 + b0, a10 * s0 + a11 * s1 + b1
        out[start + i] = min(max(s0, 0.0), p_max)
    return s0, s1


# --- muscle --------------------------------------------------------------------------------
def softplus(z: float) -> float:
    """log(1 + e^z), overflow-free (the contact band's smooth threshold, ``models.muscle``)."""
    return (z if z > 0.0 else 0.0) + math.log1p(math.exp(-abs(z)))


def _effective_pressure(p: float, mp: McKibbenRecord) -> float:
    w, pth = mp.w, mp.pth
    p = p if p > 0.0 else 0.0
    if w <= 0.0:
        return p - pth if p > pth else 0.0
    z = (p - pth) / w
    e = w * softplus(z) - mp.e0
    return e if e > 0.0 else 0.0


def backbone(e: float, x: float, mp: McKibbenRecord) -> tuple[float, float]:
    """(F_bb N, -dF_bb/dx N/m) at the effective pressure e Pa and contraction x m: g(x) e -
    k_bl x, the stretch and lock-up stiffnesses past 0 and x_l (``models.muscle``)."""
    g0, gm, xm, n, gr = mp.g0, mp.gm, mp.xm, mp.n, mp.gr
    if x <= xm:
        r = 1.0 - x / xm
        rn = r ** (n - 1.0)
        g = gm + (g0 - gm) * rn * r
        dg = -(g0 - gm) * n * rn / xm
    else:
        g = gm + gr * (x - xm)
        dg = gr
    kbl = mp.kbl
    f = g * e - kbl * x
    k = -dg * e + kbl
    if x < 0.0:
        f -= mp.ks * x
        k += mp.ks
    elif x > mp.xl:
        f -= mp.kl * (x - mp.xl)
        k += mp.kl
    return f, k


def slip_elements(s: float, load: float, fk: Values, ff0: Values, fmu: Values, z: Values,
                  zt: Slots, st: Slots) -> tuple[float, float]:
    """The Maxwell-slip elements (``models.friction``, 004 section 2.2) moved to the slip
    coordinate ``s`` m under ``load`` N >= 0 from their positions ``z`` m: element i
    (stiffness fk_i N/m, break force ff0_i + fmu_i load N) sticks while |s - z_i| < lim_i =
    (ff0_i + fmu_i load) / fk_i, else slides to s -+ lim_i. Its trial position goes to
    ``zt[i]``, 1 (sticking) or 0 to ``st[i]``. Returns (F_f = sum fk_i (s - zt_i) N, the
    sticking elements' stiffness N/m). Arrays or sequences of length n."""
    force = 0.0
    k_stick = 0.0
    for i in range(len(fk)):
        k = fk[i]
        lim = (ff0[i] + fmu[i] * load) / k
        zi = z[i]
        d = s - zi
        if d >= lim:
            zi = s - lim
            st[i] = 0
        elif d <= -lim:
            zi = s + lim
            st[i] = 0
        else:
            k_stick += k
            st[i] = 1
        zt[i] = zi
        force += k * (s - zi)
    return force, k_stick


def friction_on_backbone(f_bb: float, k_bb: float, x: float, hysteresis: float, ct: float,
                         fk: Values, ff0: Values, fmu: Values, z: Values, zt: Slots,
                         st: Slots) -> tuple[float, float, float, float]:
    """A bench muscle at contraction ``x`` m from its backbone (F_bb N, K_bb = -dF_bb/dx N/m):
    with ``hysteresis`` (1) the braid friction F_f on s = x + c_t F_bb^+ under the load F_bb^+
    (``slip_elements``; trial state into ``zt``, ``st``), F = F_bb - F_f, never pushing, and
    -dF/dx = K_bb + K_stick (1 - c_t K_bb while the braid is under tension). Returns
    (F N, -dF/dx N/m, F_f N, K_stick N/m); F <= 0 gives (0, 0, F_f, K_stick)."""
    ff = 0.0
    kf = 0.0
    k_stick = 0.0
    if hysteresis != 0.0:
        tension = f_bb if f_bb > 0.0 else 0.0
        ff, k_stick = slip_elements(x + ct * tension, tension, fk, ff0, fmu, z, zt, st)
        kf = k_stick * (1.0 - ct * k_bb if f_bb > 0.0 else 1.0)
    f = f_bb - ff
    if f <= 0.0:
        return 0.0, 0.0, ff, k_stick
    return f, k_bb + kf, ff, k_stick


def _muscle_trial(e: float, x: float, mp: McKibbenRecord, fk: Array, ff0: Array, fmu: Array,
                  z: Array, zt: Array, st: Array) -> tuple[float, float, float]:
    """(F, -dF/dx, friction) of the McKibben muscle at (e(p), x); the friction elements'
    trial state into zt, st."""
    f_bb, k_bb = backbone(e, x, mp)
    f, k, ff, _ = friction_on_backbone(f_bb, k_bb, x, mp.hysteresis, mp.ct, fk, ff0, fmu, z,
                                       zt, st)
    return f, k, ff


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


def suffix_extremes(values: Values, hi: Slots, lo: Slots) -> None:
    """``hi[j]``, ``lo[j]`` = max, min of ``values[j:]`` for every j (``hi``, ``lo`` start as
    copies of ``values``), shapes (n,)."""
    for j in range(len(values) - 2, -1, -1):
        hi[j] = hi[j] if hi[j] > hi[j + 1] else hi[j + 1]
        lo[j] = lo[j] if lo[j] < lo[j + 1] else lo[j + 1]


# --- drive ---------------------------------------------------------------------------------
def drive_play(f: float, dp: DriveRecord) -> float:
    a = f / dp.backlash_force_n
    return dp.half_play * (1.0 if a > 1.0 else (-1.0 if a < -1.0 else a))


def drive_prepare(d: float, dp: DriveRecord, ds: Slots, mode: int, sp: float) -> Prep:
    """The sub-step of length d: its ``Prep`` (the torque and the integral as affine
    functions of the end force, the position loop's rate when it fixes one)."""
    r, j, c = dp.r, dp.j, dp.c
    den = 1.0 + d * c / j
    if mode == MODE_FORCE:
        e0 = sp - ds[FORCE]
        ki = dp.force_ki
        gain = dp.force_kp + dp.force_kd / d
        integrate = abs(e0) <= dp.force_band
        if integrate:
            gain += ki * d
        t0 = r * (sp * (1.0 + gain) + ki * ds[INTEGRAL] - dp.force_kd * e0 / d)
        if integrate:
            i0, i1 = ds[INTEGRAL] + d * sp, -d
        else:
            i0, i1 = ds[INTEGRAL], 0.0
        return Prep(d, den, t0, -r * gain, i0, i1,
                    0.25 * dp.force_limit / ki if ki > 0.0 else math.inf, ki, 0.0, 0.0)
    if mode == MODE_POSITION:
        kp, kd, ki = dp.position_kp, dp.position_kd, dp.position_ki
        i_lim = 0.25 * dp.force_limit / ki if ki > 0.0 else math.inf
        i_c = ds[INTEGRAL] + d * (r * ds[ENCODER] - sp)
        w_new = ((j * ds[W] / d - r * kp * (r * ds[PHI] - sp) - r * ki * i_c)
                 / (j / d + c + r * r * kd + r * r * kp * d + r * r * ki * d * d))
        i_new = min(max(i_c + d * d * r * w_new, -i_lim), i_lim)
        t0 = r * (kp * (r * (ds[PHI] + d * w_new) - sp) + kd * r * w_new + ki * i_new)
        return Prep(d, den, t0, r, i_new, 0.0, math.inf, 0.0, w_new, 1.0)
    return Prep(d, den, 0.0, 0.0, 0.0, 0.0, math.inf, 0.0, 0.0, 0.0)


def drive_end(f: float, dp: DriveRecord, ds: Slots, prep: Prep
         ) -> tuple[float, float, float, float, bool]:
    """(phi_+, w_+, I_+, tau_+, saturated) of the prepared sub-step for the force f."""
    d, den, t0, t1, i0, i1, i_lim, ki = (prep.d, prep.den, prep.t0, prep.t1, prep.i0,
                                         prep.i1, prep.i_lim, prep.ki)
    r, j = dp.r, dp.j
    tau_max = dp.tau_max
    tau = t0 + t1 * f
    sat = abs(tau) > tau_max
    if sat:
        tau = tau_max if tau > 0.0 else -tau_max
        i_new = ds[INTEGRAL]
        w = (ds[W] + d / j * (r * f - tau)) / den
    else:
        i_new = i0 + i1 * f
        if i_new > i_lim or i_new < -i_lim:
            i_new = i_lim if i_new > 0.0 else -i_lim
            tau += ki * r * (i_new - i0 - i1 * f)
        if prep.has_w_pos != 0.0:
            w = prep.w_pos
        else:
            w = (ds[W] + d / j * (r * f - tau)) / den
    wm = dp.speed_limit
    if w > wm:
        w = wm
    elif w < -wm:
        w = -wm
    return ds[PHI] + d * w, w, i_new, tau, sat


def drive_ideal_contraction(f: float, dp: DriveRecord, ds: Slots, mode: int, sp: float) -> float:
    kb = dp.belt_stiffness
    if mode == MODE_POSITION:
        x = sp + f / kb
    else:
        target = sp if mode == MODE_FORCE else 0.0
        x = ds[CONTRACTION] + IDEAL_FORCE_COMPLIANCE_M_PER_N * (f - target)
    return min(max(x, dp.travel_min), dp.travel_max)


def drive_contraction_and_compliance(f: float, dp: DriveRecord, ds: Slots, mode: int, sp: float,
                                prep: Prep) -> tuple[float, float]:
    kb = dp.belt_stiffness
    if dp.dynamics == 0.0:                                     # the ideal holder
        x = drive_ideal_contraction(f, dp, ds, mode, sp)
        return x, (1.0 / kb if mode == MODE_POSITION else IDEAL_FORCE_COMPLIANCE_M_PER_N)
    r, j = dp.r, dp.j
    phi, w, _, _, sat = drive_end(f, dp, ds, prep)
    x = r * (phi + drive_play(f, dp)) + f / kb
    if x <= dp.travel_min:
        return dp.travel_min, 0.0
    if x >= dp.travel_max:
        return dp.travel_max, 0.0
    d, den, t1 = prep.d, prep.den, prep.t1
    if abs(w) >= dp.speed_limit or (prep.has_w_pos != 0.0 and not sat):
        dw = 0.0
    elif sat:
        dw = d / j * r / den
    else:
        dw = d / j * (r - t1) / den
    bf = dp.backlash_force_n
    play = dp.half_play / bf if abs(f) < bf else 0.0
    return x, r * (d * dw + play) + 1.0 / kb


def drive_commit(f: float, dp: DriveRecord, ds: Slots, mode: int, sp: float, prep: Prep) -> None:
    kb = dp.belt_stiffness
    r = dp.r
    if dp.dynamics == 0.0:                                     # the ideal holder
        x = drive_ideal_contraction(f, dp, ds, mode, sp)
        ds[PHI] = (x - f / kb) / r
        ds[W] = 0.0
        torque = r * f
        sat = abs(torque) > dp.tau_max
        if sat:
            torque = math.copysign(dp.tau_max, torque)
        ds[TORQUE] = torque
        ds[SATURATED] = 1.0 if sat else 0.0
    else:
        phi, w, i_new, tau, sat = drive_end(f, dp, ds, prep)
        x = r * (phi + drive_play(f, dp)) + f / kb
        if x < dp.travel_min or x > dp.travel_max:
            x = dp.travel_min if x < dp.travel_min else dp.travel_max
            phi = (x - f / kb) / r - drive_play(f, dp)
            w = 0.0
        ds[PHI], ds[W], ds[INTEGRAL] = phi, w, i_new
        ds[TORQUE] = tau
        ds[SATURATED] = 1.0 if sat else 0.0
    ds[FORCE] = f
    ds[CONTRACTION] = x
    angle = ds[PHI] + drive_play(f, dp)
    ds[ENCODER] = round(angle / dp.count_rad) * dp.count_rad


# --- the coupled sub-steps -----------------------------------------------------------------
def _solve_mckibben(steps: Array, pressures: Array, f: float, mp: McKibbenRecord, fk: Array,
                    ff0: Array, fmu: Array, z: Array, st: Array, dp: DriveRecord, ds: Array,
                    mode: int, sp: float, out_f: Array, out_x: Array, tol: Array
                    ) -> tuple[float, float, int, int, int]:
    """Every sub-step of an exchange (``models.coupling.solve_substeps``) for a McKibben muscle
    on the loading drive. ``z``, ``st`` (friction) and ``ds`` (drive) are updated in place;
    forces and contractions go to ``out_f``, ``out_x``. ``tol``: the settle tolerances (force
    N, contraction m, pressure Pa; negative: never settle), shape (3,). Returns (stiffness
    -dF/dx N/m and friction N at the end, Newton iterations, status: ``OK`` or
    ``BAD_POSITION``, sub-steps held)."""
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
        e = _effective_pressure(p, mp)
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
            tf, tk, tff = _muscle_trial(e, x, mp, fk, ff0, fmu, z, zt, stt)
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
        if mp.hysteresis != 0.0:
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


def _replay_drive(steps: Array, forces: Array, dp: DriveRecord, ds: Array, mode: int,
                  sp: float) -> None:
    """Follow the sub-steps a coupled solve took (``LoadingServoModel.replay``): prepare and
    commit each with its end force; ``ds`` updated in place."""
    prep = NO_PREP
    for idx in range(steps.shape[0]):
        if dp.dynamics != 0.0:
            prep = drive_prepare(steps[idx], dp, ds, mode, sp)
        drive_commit(forces[idx], dp, ds, mode, sp, prep)


_HELPERS = ('softplus', '_effective_pressure', 'backbone', 'slip_elements',
            'friction_on_backbone', '_muscle_trial', 'newton_next', 'suffix_extremes',
            'drive_play', 'drive_prepare', 'drive_end', 'drive_ideal_contraction',
            'drive_contraction_and_compliance', 'drive_commit')
"""Called by the kernels: registered with numba (``register_jitable``), which compiles them
into their callers and leaves the Python functions as they are."""
_KERNELS: dict[str, Callable[..., Any]] = {
    'zoh_run': _zoh_run, 'solve_mckibben': _solve_mckibben, 'replay_drive': _replay_drive}
"""The kernels the models call, by name: each compiled into ``_COMPILED`` when loaded."""
_COMPILED: dict[str, Callable[..., Any]] = {}


def zoh_run(*args: Any) -> tuple[float, float]:
    """``_zoh_run`` compiled once loaded (else interpreted: the same function)."""
    return cast('tuple[float, float]', _COMPILED.get('zoh_run', _zoh_run)(*args))


def solve_mckibben(*args: Any) -> tuple[float, float, int, int, int]:
    """``_solve_mckibben`` compiled once loaded (else interpreted: the same function)."""
    return cast('tuple[float, float, int, int, int]',
                _COMPILED.get('solve_mckibben', _solve_mckibben)(*args))


def replay_drive(*args: Any) -> None:
    """``_replay_drive`` compiled once loaded (else interpreted: the same function)."""
    _COMPILED.get('replay_drive', _replay_drive)(*args)


def _load() -> None:
    """Compile every kernel (from numba's cache when it holds them); the Python functions
    stay what they are, the compiled ones go to ``_COMPILED``."""
    with _LOCK:
        if _READY.is_set() or _FAILED:
            return
        try:
            import numba
            from numba.extending import register_jitable
            setattr(numba.config, 'CACHE_DIR', os.environ['NUMBA_CACHE_DIR'])  # noqa: B010
            g = globals()
            for name in _HELPERS:
                register_jitable(g[name])
            compiled = {name: numba.njit(cache=True, nogil=True)(fn)
                        for name, fn in _KERNELS.items()}
            _run_each(compiled)
        except Exception as exc:  # noqa: BLE001 - the reference runs instead, and says why
            _FAILED.append(f'{type(exc).__name__}: {exc}')
            return
        _COMPILED.update(compiled)
        _READY.set()


def _run_each(g: dict[str, Any]) -> None:
    """Call every kernel once with the types a run uses (compiles or loads them)."""
    import numpy as np
    out = np.zeros(2)
    g['zoh_run'](0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 2, 1.0, out, 0)
    mp = McKibbenRecord(3e-3, 2e-4, 0.095, 1.4, 2.6e-4, 8e4, 4e4, 0.0, 350.0, 1e5, 5e5, 0.15,
                        1.0, 8e-7)
    dp = DriveRecord(0.032, 0.15, 0.5, 88.0, 1e-3, 1e-4, 5.0, 2e6, -0.05, 0.16, 4.5, 5.0, 12.0,
                     1.8, 25.0, 2e6, 1e7, 3e4, 2792.0, 1.0)
    ds = np.zeros(STATE_SIZE)
    g['solve_mckibben'](np.full(2, 0.005), np.full(2, 1e5), 0.0, mp, np.array([1e5]),
                        np.ones(1), np.full(1, 0.01), np.zeros(1), np.ones(1, np.uint8), dp,
                        ds, MODE_POSITION, 0.0, np.zeros(2), np.zeros(2), np.full(3, -1.0))
    g['replay_drive'](np.full(2, 0.005), np.full(2, 10.0), dp, ds, MODE_FORCE, 10.0)


def warm_up() -> float:
    """Compile (or load from the cache) every kernel now; returns the seconds it took.

    Raises:
        RuntimeError: numba cannot compile them (the message says why).
    """
    t0 = time.perf_counter()
    _load()
    if _FAILED:
        raise RuntimeError(f'the compiled core does not load: {_FAILED[0]}')
    return time.perf_counter() - t0
