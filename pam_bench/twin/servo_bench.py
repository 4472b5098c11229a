"""The torque servo's bench in one process with numpy, exchange for exchange as the nodes.

Two valves, two muscles, two load cells and the encoder on the pulley, whose angle the electric
servo holds (004 section 3.2: "the electric servo holds the angle, the muscles make the
torque"); with ``muscles = 1`` the single-muscle force check of 004 section 3.1, the loading
servo holding x in position mode. Per exchange step h, in the nodes' order:

    valve_i:   p_i    = valve_i.samples(u_i, h, V_i)     (u_i sent at the previous tick)
    muscle_i:  F_i    = solved with its holder on the sub-step (``models.coupling``):
               x_1 = x0 + r theta + F_1 / k_b,  x_2 = x0 - r theta + F_2 / k_b  (belt stretch),
               or the loading servo's law with one muscle
    cell_i:    F_m,i  = cell_i.measure(F_i)
    servo:     u_i    = controller(F_m,i, theta_m of the previous tick)       (every exchange)

Used for the controller comparison's reference, the tuning, and the closed-loop rows of the
work-precision benchmark.
"""

from __future__ import annotations

import dataclasses
from typing import Any, TypedDict

import numpy as np

from pam_bench.control.inverse import InverseModel
from pam_bench.control.torque_servo import (
    ServoMode,
    Signal,
    TorqueServoController,
    TorqueServoParams,
)
from pam_bench.models.coupling import solve_substeps
from pam_bench.models.loading_servo import (
    IdealHold,
    LoadingServoModel,
    LoadingServoParams,
    LoadMode,
)
from pam_bench.models.muscle import MuscleModel, MuscleParams
from pam_bench.models.sensors import EncoderModel, LoadCellModel, LoadCellParams
from pam_bench.models.valve import ValveModel, ValveParams

__all__ = ['ServoRun', 'run_servo', 'reversals', 'tracking_metrics', 'Tracking']


class Tracking(TypedDict):
    """How well a servo run tracked (``tracking_metrics``): RMS and largest error, the
    largest near a reversal and elsewhere (the run's unit, ``unit``: 'N m' or 'N'), and the
    window after a reversal that counts as near it, s."""

    rms_error: float
    max_error: float
    error_at_reversal: float
    error_elsewhere: float
    reversal_window_s: float
    unit: str


@dataclasses.dataclass
class ServoRun:
    """Time series of a servo run, shapes (n,) or (n, muscles): s, N m or N, V."""

    t_s: np.ndarray
    setpoint: np.ndarray
    measured: np.ndarray
    setpoint_rate: np.ndarray
    force_setpoint_n: np.ndarray
    force_n: np.ndarray
    voltage_v: np.ndarray
    u_feedforward_v: np.ndarray
    unit: str


def run_servo(mode: ServoMode | str, signal: Signal, duration_s: float,
              angle_rad: float = 0.0, h_s: float = 0.001, inverse: InverseModel | None = None,
              muscles: int = 2, params: TorqueServoParams | None = None,
              valve: ValveParams | None = None, muscle: MuscleParams | None = None,
              noise: bool = True, seed: int = 0, plugins: Any = None) -> ServoRun:
    """Run the closed loop for ``duration_s`` at exchange step ``h_s`` with the controller
    ``mode`` (built-in, or a plug-in's name with its settings among ``plugins``)."""
    sp = params or TorqueServoParams()
    name = mode.value if isinstance(mode, ServoMode) else mode
    ctl = TorqueServoController(sp, mode, inverse, muscles, getattr(plugins, name, None))
    valves = [ValveModel(valve) for _ in range(muscles)]
    ms = [MuscleModel(muscle) for _ in range(muscles)]
    cells = [LoadCellModel(LoadCellParams(noise=noise), seed=seed + i) for i in range(muscles)]
    enc = EncoderModel()
    k_b = LoadingServoParams().belt_stiffness_n_per_m
    r = ctl.r
    sign = (1.0, -1.0)
    x0 = [sp.rest_contraction_m + sign[i] * r * angle_rad for i in range(muscles)]
    holders: list[Any]
    if muscles == 2:
        holders = [IdealHold(x, k_b) for x in x0]
    else:
        drive = LoadingServoModel()
        drive.command(LoadMode.POSITION, x0[0])
        drive.reset(x0[0])
        holders = [drive]
    for m, xi in zip(ms, x0, strict=True):
        m.reset(xi, 0.0)
    vol = [m.volume(0.0) for m in ms]       # as the muscle node reports it at t_0
    f = [0.0] * muscles                     # true forces
    f_meas = [0.0] * muscles                # what the controller reads (previous tick)
    th_meas = 0.0
    u = [0.0] * muscles                     # commands of the previous tick
    n = int(round(duration_s / h_s))
    rec: dict[str, list[Any]] = {k: [] for k in ('t', 'sp', 'meas', 'rate', 'fsp', 'f', 'u',
                                                 'ff')}
    for k in range(n):
        t = k * h_s
        # devices over the exchange on the previous tick's commands
        for i in range(muscles):
            p = valves[i].samples(u[i], [h_s], vol[i])
            res = solve_substeps(ms[i], holders[i], [h_s], p, f[i])
            f[i] = res.forces_n[-1]
            vol[i] = ms[i].volume(res.contractions_m[-1])
        new_meas = [c.measure(fi) for c, fi in zip(cells, f, strict=True)]
        angle = holders[0].angle if muscles == 1 else angle_rad
        # the controller at this tick on the measurements of the previous one
        s, ds, dds = signal.value_and_rates(t)
        if muscles == 2:
            s, _ = ctl.clamp_torque(s)
        ch = ctl.step(h_s, (s, ds, dds), th_meas, tuple(f_meas))
        u = [c.voltage_v for c in ch]
        rec['t'].append(t)
        rec['sp'].append(s)
        rec['rate'].append(ds)
        rec['meas'].append(r * (f_meas[0] - f_meas[1]) if muscles == 2 else f_meas[0])
        rec['fsp'].append([c.force_setpoint_n for c in ch])
        rec['f'].append(list(f_meas))
        rec['u'].append(u)
        rec['ff'].append([c.u_feedforward_v for c in ch])
        f_meas = new_meas
        th_meas = enc.measure(angle, h_s)[0]
    a = {k: np.asarray(v) for k, v in rec.items()}
    return ServoRun(a['t'], a['sp'], a['meas'], a['rate'], a['fsp'], a['f'], a['u'], a['ff'],
                    'N m' if muscles == 2 else 'N')


def reversals(run: ServoRun, settle_s: float = 0.0) -> np.ndarray:
    """Times (s) after ``settle_s`` where the set point's derivative changes sign, or a square
    wave jumps, shape (n,)."""
    keep = run.t_s >= settle_s
    t = run.t_s[keep]
    if len(t) < 2:
        return np.array([])
    rate = run.setpoint_rate[keep]
    jumps = np.abs(np.diff(run.setpoint[keep])) > 0.1 * max(float(np.ptp(run.setpoint)), 1e-9)
    flips = np.nonzero(np.sign(rate[1:]) * np.sign(rate[:-1]) < 0)[0]
    return np.sort(np.concatenate([t[1:][flips], t[1:][jumps]]))


def tracking_metrics(run: ServoRun, settle_s: float = 1.0, window_s: float | None = None
                     ) -> Tracking:
    """RMS and max |set point - measured| after ``settle_s``; the largest error in the window
    that follows a reversal of the set point's derivative (or a jump of a square wave) and the
    largest elsewhere, in the run's unit. The window runs from 0.05 s before each reversal to
    a quarter of the spacing between reversals after it (``window_s`` overrides the latter):
    friction shows there, the error building up after the muscles change direction."""
    keep = run.t_s >= settle_s
    e = np.abs(run.setpoint - run.measured)[keep]
    t = run.t_s[keep]
    marks = reversals(run, settle_s)
    if window_s is None:
        window_s = 0.25 * float(np.median(np.diff(marks))) if len(marks) > 1 else 0.1
    near = np.zeros_like(t, dtype=bool)
    for m in marks:
        near |= (t >= m - 0.05) & (t <= m + window_s)
    return Tracking(rms_error=float(np.sqrt(np.mean(e ** 2))) if len(e) else float('nan'),
                    max_error=float(e.max()) if len(e) else float('nan'),
                    error_at_reversal=float(e[near].max()) if near.any() else float('nan'),
                    error_elsewhere=float(e[~near].max()) if (~near).any() else float('nan'),
                    reversal_window_s=window_s, unit=run.unit)
