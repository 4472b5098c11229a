"""The loading drive's backward-Euler sub-step, written once for the reference and numba.

The law is the one ``models.loading_servo.drive`` states (its docstring, 'Sub-step law'; 004
section 2.1): ``drive_prepare`` fixes what a sub-step of length d does not owe to the end force
F_+ (the torque tau_+ = t0 + t1 F_+ and the integral I_+ = i0 + i1 F_+ before their limits),
``drive_contraction_and_compliance`` gives the muscle end x_+ = X(F_+) m and dX/dF m/N, and
``drive_commit`` takes the sub-step with the force found. The state is one float array (``PHI``
rad, ``W`` rad/s, ``INTEGRAL``, ``FORCE`` N, ``ENCODER`` rad, ``CONTRACTION`` m, ``TORQUE``
N m, ``SATURATED`` 0/1); ``replay_drive`` follows the sub-steps of a coupled solve
(``models.coupling``) with their end forces. Every function runs interpreted for the
reference and compiled by ``models.jit``, bit-equal.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from pam_bench.models import jit
from pam_bench.models.jit import Array, Slots

__all__ = ['DriveRecord', 'Prep', 'NO_PREP', 'PHI', 'W', 'INTEGRAL', 'FORCE', 'ENCODER',
           'CONTRACTION', 'TORQUE', 'SATURATED', 'STATE_SIZE', 'MODE_OFF', 'MODE_FORCE',
           'MODE_POSITION', 'IDEAL_FORCE_COMPLIANCE_M_PER_N', 'drive_play', 'drive_prepare',
           'drive_end', 'drive_ideal_contraction', 'drive_contraction_and_compliance',
           'drive_commit', 'replay_drive']


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
IDEAL_FORCE_COMPLIANCE_M_PER_N = 1.0e-3
"""m/N: how much the ideal holder gives per newton (``holders.IdealHold``)."""


@jit.helper
def drive_play(f: float, dp: DriveRecord) -> float:
    """beta(F) rad: where the pulley sits inside the play under the force F N."""
    a = f / dp.backlash_force_n
    return dp.half_play * (1.0 if a > 1.0 else (-1.0 if a < -1.0 else a))


@jit.helper
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


@jit.helper
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


@jit.helper
def drive_ideal_contraction(f: float, dp: DriveRecord, ds: Slots, mode: int, sp: float) -> float:
    """x_+ m of the ideal holder (no drive mechanics) under the end force F N."""
    kb = dp.belt_stiffness
    if mode == MODE_POSITION:
        x = sp + f / kb
    else:
        target = sp if mode == MODE_FORCE else 0.0
        x = ds[CONTRACTION] + IDEAL_FORCE_COMPLIANCE_M_PER_N * (f - target)
    return min(max(x, dp.travel_min), dp.travel_max)


@jit.helper
def drive_contraction_and_compliance(f: float, dp: DriveRecord, ds: Slots, mode: int, sp: float,
                                prep: Prep) -> tuple[float, float]:
    """X(F_+) m and dX/dF m/N of the prepared sub-step ``prep`` for the end force F_+ N."""
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


@jit.helper
def drive_commit(f: float, dp: DriveRecord, ds: Slots, mode: int, sp: float, prep: Prep) -> None:
    """Take the prepared sub-step with the end force F_+ N: ``ds`` updated in place."""
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


def _replay_drive(steps: Array, forces: Array, dp: DriveRecord, ds: Array, mode: int,
                  sp: float) -> None:
    """Follow the sub-steps a coupled solve took (``LoadingServoModel.replay``): prepare and
    commit each with its end force; ``ds`` updated in place."""
    prep = NO_PREP
    for idx in range(steps.shape[0]):
        if dp.dynamics != 0.0:
            prep = drive_prepare(steps[idx], dp, ds, mode, sp)
        drive_commit(forces[idx], dp, ds, mode, sp, prep)


def _replay_example() -> tuple[Any, ...]:
    dp = DriveRecord(0.032, 0.15, 0.5, 88.0, 1e-3, 1e-4, 5.0, 2e6, -0.05, 0.16, 4.5, 5.0, 12.0,
                     1.8, 25.0, 2e6, 1e7, 3e4, 2792.0, 1.0)
    return np.full(2, 0.005), np.full(2, 10.0), dp, np.zeros(STATE_SIZE), MODE_FORCE, 10.0


replay_drive = jit.kernel('replay_drive', _replay_drive, _replay_example)
