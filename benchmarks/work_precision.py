"""Work-precision of the models: error against a reference versus wall time, per scheme and step.

Rows (each: model, scheme, step h, max error, relative error, wall time per simulated second):

- valve: the pressure loop's step 1 V -> 5 V at a held chamber volume. Reference: scipy
  ``solve_ivp`` Radau at rtol 1e-12 (and the exact ZOH, which must agree to <= 1e-12).
  Schemes: zoh (exact), rk4, euler, one step per exchange.
- muscle: the braid friction along p(t) = 0.3 + 0.2 sin(2 pi t) MPa at x = 40 mm, sampled every
  h. Reference: the same path sampled every 10 us. The Maxwell-slip projection is exact on a
  monotone piece, so the error is what coarse samples miss at the reversals.
- drive: the loading servo in force mode (set value 300 -> 320 N) against a linear spring
  muscle F = F_0 - K x (K = 6e5 N/m, the braid sticking), over 1 s sampled every 0.1 s. The
  drive's own scheme is its backward-Euler sub-step law, implicit in the force
  (``LoadingServoModel``, solved with the spring by ``models.coupling``); explicit Euler and
  RK4 of the same continuous equations are the alternatives. Reference: the exact solution
  of the continuous linear system (matrix exponential).
- torque loop: 5 sin t N m with the identified model + PID on the numpy twin at exchange step h.
  Reference: h = 0.1 ms; error = largest torque difference at common instants.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
from scipy.integrate import solve_ivp

from pam_bench.models.coupling import solve_substep
from pam_bench.models.loading_servo import LoadingServoModel, LoadingServoParams, LoadMode
from pam_bench.models.muscle import MuscleModel
from pam_bench.models.valve import ValveModel, ValveParams

__all__ = ['valve_rows', 'muscle_rows', 'drive_rows', 'torque_loop_rows', 'fastest_within',
           'work_precision']

VOLUME_M3 = 1.1e-4


def _row(model: str, scheme: str, h: float, err: float, scale: float, wall: float,
         sim_s: float, unit: str) -> dict[str, Any]:
    return {'model': model, 'scheme': scheme, 'step_s': h, 'max_error': err, 'unit': unit,
            'relative_error': err / scale, 'wall_s_per_sim_s': wall / sim_s}


def valve_rows(steps: list[float]) -> list[dict[str, Any]]:
    """Valve step response error per scheme and step (module docstring)."""
    v = ValveModel()
    a, b = v.matrices(VOLUME_M3)
    v.reset(1e5)
    t_end = 1.0
    sol = solve_ivp(lambda t, s: a @ s + b[:, 0] * 5e5, (0.0, t_end), [1e5, 0.0], method='Radau',
                    rtol=1e-12, atol=1e-9, dense_output=True)
    rows = []
    for scheme in ('zoh', 'rk4', 'euler'):
        for h in steps:
            m = ValveModel(ValveParams(scheme=scheme))
            m.reset(1e5)
            n = int(round(t_end / h))
            t0 = time.perf_counter()
            with np.errstate(all='ignore'):
                p = np.array([m.step(5.0, h, VOLUME_M3) if np.isfinite(m.state).all()
                              else np.nan for _ in range(n)])
                raw = np.array(m.state[0])
            wall = time.perf_counter() - t0
            ref = sol.sol(np.arange(1, n + 1) * h)[0]
            err = float(np.max(np.abs(np.clip(ref, 0, 1e6) - p))) if np.isfinite(p).all() \
                and np.isfinite(raw) else float('inf')
            rows.append(_row('valve', scheme, h, err, 4e5, wall, t_end, 'Pa'))
    return rows


def muscle_rows(steps: list[float]) -> list[dict[str, Any]]:
    """Friction path sampling error (module docstring)."""
    def path(h: float) -> tuple[np.ndarray, np.ndarray, float]:
        m = MuscleModel()
        m.reset(0.04, 3e5)
        t = np.arange(0.0, 2.0 + 1e-12, h)
        t0 = time.perf_counter()
        f = np.array([m.step(3e5 + 2e5 * np.sin(2 * np.pi * tk), 0.04).friction_n for tk in t])
        return t, f, time.perf_counter() - t0

    t_ref, f_ref, _ = path(1e-5)
    scale = float(np.ptp(f_ref))
    rows = []
    for h in steps:
        t, f, wall = path(h)
        ref = np.interp(t, t_ref, f_ref)
        rows.append(_row('muscle friction', 'projection', h, float(np.max(np.abs(f - ref))),
                         scale, wall, 2.0, 'N'))
    return rows


SPRING_N_PER_M = 6.0e5
SPRING_F0_N = 300.0 + SPRING_N_PER_M * 0.05       # 300 N at x = 50 mm


class _Spring:
    """A linear spring muscle F = F_0 - K x with the muscle's trial/commit interface."""

    def trial(self, p: float, x: float) -> tuple[float, float, float, None]:
        return max(SPRING_F0_N - SPRING_N_PER_M * x, 0.0), SPRING_N_PER_M, 0.0, None

    def commit(self, trial: object) -> None:
        """Nothing to keep."""


def _drive_start() -> LoadingServoModel:
    srv = LoadingServoModel()
    srv.command(LoadMode.FORCE, 300.0)
    # at rest in equilibrium at 300 N (x = 50 mm + belt), integral holding it
    f = 300.0
    x = (SPRING_F0_N - f) / SPRING_N_PER_M
    srv.force_n, srv.contraction_m = f, x
    srv.phi = (x - f / srv.p.belt_stiffness_n_per_m) / srv.r - srv.half_play
    srv.command(LoadMode.FORCE, 320.0)
    return srv


def _drive_linear() -> tuple[np.ndarray, np.ndarray, float, float]:
    """The continuous drive + spring as s' = A s + b, s = (phi, w, I): (A, b, a_x, c_x) with
    x = a_x phi + c_x (belt stretch and play, F > F_bl)."""
    p = LoadingServoParams()
    srv = _drive_start()
    r, k, kb = srv.r, SPRING_N_PER_M, p.belt_stiffness_n_per_m
    den = 1.0 + k / kb
    a_x, c_x = r / den, (r * srv.half_play + SPRING_F0_N / kb) / den
    # F = F0 - K x;  e = F* - F;  e' = K a_x w
    fs = 320.0
    j, c = p.inertia_kg_m2, p.damping_nm_s_per_rad
    f_phi, f_1 = -k * a_x, SPRING_F0_N - k * c_x          # F = f_phi phi + f_1
    # J w' = r F - r [F* + Kp e + Ki I + Kd e'] - c w
    a = np.zeros((3, 3))
    b = np.zeros(3)
    a[0, 1] = 1.0
    a[1, 0] = (r * f_phi + r * p.force_kp * f_phi) / j
    a[1, 1] = (-c - r * p.force_kd_s * k * a_x) / j
    a[1, 2] = -r * p.force_ki_per_s / j
    b[1] = (r * f_1 - r * (fs + p.force_kp * (fs - f_1))) / j
    a[2, 0] = -f_phi
    b[2] = fs - f_1
    return a, b, a_x, c_x


def drive_rows(steps: list[float]) -> list[dict[str, Any]]:
    """Loading servo force loop per scheme against the exact solution (module docstring)."""
    from scipy.linalg import expm
    a, b, a_x, c_x = _drive_linear()
    srv0 = _drive_start()
    s0 = np.array([srv0.phi, 0.0, 0.0])
    blk = np.zeros((4, 4))
    blk[:3, :3], blk[:3, 3] = a, b
    times = np.arange(1, 11) * 0.1
    ref = np.array([a_x * (expm(blk * t) @ np.append(s0, 1.0))[0] + c_x for t in times])
    scale = abs(ref[-1] - (a_x * s0[0] + c_x))
    rows = []
    for h in steps:
        n = int(round(1.0 / h))
        every = int(round(0.1 / h))
        t0 = time.perf_counter()
        srv, spring, f, xs = _drive_start(), _Spring(), 300.0, []
        holder: Any = spring
        for k in range(n):
            f, x, *_ = solve_substep(holder, srv, h, 0.0, f)
            if (k + 1) % every == 0:
                xs.append(x)
        wall = time.perf_counter() - t0
        rows.append(_row('drive', 'backward euler', h, float(np.max(np.abs(np.array(xs) - ref))),
                         scale, wall, 1.0, 'm'))
    for scheme in ('rk4', 'euler'):
        for h in [v for v in steps if v <= 2e-3]:
            n, every = int(round(1.0 / h)), int(round(0.1 / h))
            t0 = time.perf_counter()
            st, xs = s0.copy(), []
            with np.errstate(all='ignore'):
                for k in range(n):
                    if scheme == 'euler':
                        st = st + h * (a @ st + b)
                    else:
                        k1 = a @ st + b
                        k2 = a @ (st + 0.5 * h * k1) + b
                        k3 = a @ (st + 0.5 * h * k2) + b
                        k4 = a @ (st + h * k3) + b
                        st = st + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
                    if (k + 1) % every == 0:
                        xs.append(a_x * st[0] + c_x)
            wall = time.perf_counter() - t0
            xa = np.array(xs)
            err = float(np.max(np.abs(xa - ref))) if np.isfinite(xa).all() else float('inf')
            rows.append(_row('drive', scheme, h, err, scale, wall, 1.0, 'm'))
    return rows


def torque_loop_rows(steps: list[float], inverse: Any) -> list[dict[str, Any]]:
    """Closed torque loop at exchange step h against h = 0.1 ms (module docstring)."""
    from pam_bench.control.torque_servo import ServoMode, Signal, SignalKind
    from pam_bench.twin.servo_bench import run_servo
    sig = Signal(SignalKind.SINE, 5.0, 1.0)
    dur = 3.0
    ref = run_servo(ServoMode.DYNAMIC, sig, dur, h_s=1e-4, inverse=inverse, noise=False)
    rows = []
    for h in steps:
        t0 = time.perf_counter()
        run = run_servo(ServoMode.DYNAMIC, sig, dur, h_s=h, inverse=inverse, noise=False)
        wall = time.perf_counter() - t0
        refm = np.interp(run.t_s, ref.t_s, ref.measured)
        err = float(np.max(np.abs(run.measured - refm))) if np.isfinite(run.measured).all() \
            else float('inf')
        rows.append(_row('torque loop', 'exchange', h, err, 5.0, wall, dur, 'N m'))
    return rows


def fastest_within(rows: list[dict[str, Any]], tol: float = 1e-3) -> dict[str, Any]:
    """Per model: the fastest row with relative error <= tol (None if no row qualifies)."""
    out: dict[str, Any] = {}
    for model in dict.fromkeys(r['model'] for r in rows):
        ok = [r for r in rows if r['model'] == model and r['relative_error'] <= tol]
        out[model] = min(ok, key=lambda r: r['wall_s_per_sim_s']) if ok else None
    return out


def zoh_exactness() -> float:
    """Largest relative error of the valve's exact ZOH against the closed form of a 2nd-order
    step (three damping regimes, 1 ms steps over 1 s)."""
    worst = 0.0
    for zeta in (0.3, 1.0, 3.0):
        v = ValveModel(ValveParams(damping_ratio=zeta, volume_scaling=False))
        w = v.p.natural_frequency_rad_s
        for k in range(1, 1001):
            p = v.step(1.0, 1e-3)
            t = k * 1e-3
            if zeta < 1:
                wd = w * math.sqrt(1 - zeta ** 2)
                y = 1 - math.exp(-zeta * w * t) * (math.cos(wd * t)
                                                   + zeta * w / wd * math.sin(wd * t))
            elif zeta == 1:
                y = 1 - math.exp(-w * t) * (1 + w * t)
            else:
                r = w * math.sqrt(zeta ** 2 - 1)
                s1, s2 = -zeta * w + r, -zeta * w - r
                y = 1 + (s2 * math.exp(s1 * t) - s1 * math.exp(s2 * t)) / (s1 - s2)
            worst = max(worst, abs(p / 1e5 - y) / max(abs(y), 1e-3))
    return worst


def work_precision(quick: bool, inverse: Any) -> dict[str, Any]:
    """All rows, the fastest scheme within 0.1 % per model and the ZOH exactness."""
    steps = [1e-4, 1e-3, 5e-3, 2e-2] if quick else [1e-4, 5e-4, 1e-3, 2e-3, 5e-3, 1e-2, 2e-2,
                                                     5e-2]
    rows = valve_rows(steps) + muscle_rows([s for s in steps if s >= 1e-4])
    rows += drive_rows([s for s in steps if s >= 1e-4])
    rows += torque_loop_rows([s for s in steps if 2.5e-4 <= s <= 5e-3], inverse)
    return {'rows': rows, 'fastest_within_0.1pct': fastest_within(rows),
            'zoh_max_relative_error': zoh_exactness()}
