"""The single-muscle bench at equilibrium: each reading solved directly, no time stepping.

Every reading of a protocol is the state the bench settles to after its dwell. With the valve
settled (p = p_ss(u) = k_v u, valve module) and the loading servo at its set value, the muscle
end obeys (004 section 2.1 geometry, loading_servo module):

    position mode:  x_t = x_enc + F / k_b,   F = F_m(p, x_t)        (belt stretch k_b)
    force mode:     F_m(p, x_t) = F*,        x_enc = x_t - F* / k_b
    F_m(p, x) = max(0, F_bb(p, x) - F_f(s)),   s = x + kappa_p p     (muscle module)

F_m is non-increasing in x_t (the gain g(x) falls with x, the bladder and friction springs
resist contraction), so force mode has one root, found with Brent's method; position mode is a
contraction mapping (|dF/dx| / k_b < 0.02) solved by fixed-point iteration. The friction state
advances from reading to reading along the protocol's path (monotone between readings: the
valve overshoot and the servo transients of the dynamic bench are left out), so the hysteresis
of the three families comes out as well. Switching ``hysteresis`` off in the muscle parameters
gives the friction-free backbone. Units SI.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np
from scipy.optimize import brentq

from pam_bench.models.bench_muscle import make_muscle
from pam_bench.models.loading_servo import LoadingServoParams, LoadMode
from pam_bench.models.muscle import MuscleParams
from pam_bench.models.straight_fibre_muscle import StraightFibreParams
from pam_bench.models.valve import ValveModel, ValveParams
from pam_bench.protocol.schedules import Reading

__all__ = ['QuasiStaticBench', 'SettledReading']


@dataclasses.dataclass(frozen=True)
class SettledReading:
    """Settled bench after one reading: u V, p Pa, F N, encoder x m, muscle x_t m."""

    voltage_v: float
    pressure_pa: float
    force_n: float
    contraction_m: float
    muscle_contraction_m: float


class QuasiStaticBench:
    """Valve, muscle and loading servo at equilibrium, friction carried along the path."""

    def __init__(self, valve: ValveParams | None = None, muscle: MuscleParams | None = None,
                 servo: LoadingServoParams | None = None,
                 straight_fibre: StraightFibreParams | None = None,
                 overshoot: bool = False, laws: Any = None) -> None:
        self.overshoot = overshoot
        self.valve = ValveModel(valve)
        self.muscle = make_muscle(muscle, straight_fibre, laws)
        self.servo = servo or LoadingServoParams()
        self.k_b = self.servo.belt_stiffness_n_per_m
        self.x_t = 0.0
        self.p = 0.0
        self.muscle.reset(0.0, 0.0)

    def _trial_force(self, p: float, x_t: float) -> float:
        """F_m(p, x_t) without committing the friction state, N."""
        return self.muscle.trial(p, x_t)[0]

    def _commit(self, p: float, x_t: float) -> float:
        """Move the muscle to (p, x_t) along a straight path and return F, N.

        The path is cut into pieces of at most 0.1 mm / 10 kPa so the friction elements see
        the reversal points a monotone move between two readings passes through."""
        n = int(max(abs(x_t - self.x_t) / 1e-4, abs(p - self.p) / 1e4, 1.0))
        for k in range(1, n + 1):
            a = k / n
            f = self.muscle.step(self.p + a * (p - self.p), self.x_t + a * (x_t - self.x_t))
        self.p, self.x_t = p, x_t
        return f.force_n

    def turning_pressures(self, p_to: float) -> list[float]:
        """The pressures where the valve's step response from the present pressure to
        ``p_to`` turns, ending at ``p_to`` (Pa). Without ``overshoot`` (or below order 2, or
        at zeta >= 1) just [p_to]; with it, p_to + (p_to - p_0)(-r)^k, k = 1, 2, ..., with
        r = exp(-zeta pi / sqrt(1 - zeta^2)) the second-order loop's overshoot per half period,
        until the swing is below 100 Pa: the braid friction is rate independent, so these
        turning points are all the settling does to it (the pressure ringing shakes the
        friction towards the middle of its loop)."""
        v = self.valve.p
        if not self.overshoot or v.order != 2 or v.damping_ratio >= 1.0:
            return [p_to]
        r = math.exp(-v.damping_ratio * math.pi / math.sqrt(1.0 - v.damping_ratio ** 2))
        out, swing = [], (p_to - self.p) * r
        while abs(swing) > 100.0:
            out.append(min(max(p_to + swing, 0.0), v.pressure_max_pa))
            swing *= -r
        return out + [p_to]

    def hold_position(self, voltage_v: float, contraction_m: float) -> SettledReading:
        """Settle with the encoder held at ``contraction_m`` (m) and u = ``voltage_v`` (V)."""
        p = self.valve.steady_pressure(voltage_v)
        for q in self.turning_pressures(p):
            x_t = self._belt_equilibrium(q, contraction_m)
            f = self._commit(q, x_t)
        return SettledReading(voltage_v, p, f, contraction_m, x_t)

    def _belt_equilibrium(self, p: float, contraction_m: float) -> float:
        """x_t = x_enc + F_m(p, x_t) / k_b by fixed-point iteration (a contraction mapping:
        |dF/dx| / k_b < 0.02), m."""
        x_t = contraction_m + self._trial_force(p, self.x_t) / self.k_b
        for _ in range(60):
            nxt = contraction_m + self._trial_force(p, x_t) / self.k_b
            done = abs(nxt - x_t) < 1e-12
            x_t = nxt
            if done:
                break
        return x_t

    def hold_force(self, voltage_v: float, force_n: float) -> SettledReading:
        """Settle with the load cell held at ``force_n`` (N) and u = ``voltage_v`` (V); the belt
        stops at the servo's travel ends."""
        p = self.valve.steady_pressure(voltage_v)
        for q in self.turning_pressures(p)[:-1]:
            self._settle_force(q, force_n)
        return self._settle_force(p, force_n, voltage_v)

    def _settle_force(self, p: float, force_n: float, voltage_v: float = 0.0
                      ) -> SettledReading:
        """The muscle at pressure ``p`` (Pa) with the load cell held at ``force_n``."""
        lo = self.servo.travel_min_m + force_n / self.k_b
        hi = self.servo.travel_max_m + force_n / self.k_b
        g_lo = self._trial_force(p, lo) - force_n
        g_hi = self._trial_force(p, hi) - force_n
        if g_lo <= 0.0:
            x_t = lo
        elif g_hi >= 0.0:
            x_t = hi
        else:
            x_t = brentq(lambda x: self._trial_force(p, x) - force_n, lo, hi, xtol=1e-10)
        f = self._commit(p, x_t)
        return SettledReading(voltage_v, p, f, x_t - force_n / self.k_b, x_t)

    def settle(self, r: Reading) -> SettledReading:
        """The reading ``r`` of a protocol schedule, after its dwell."""
        if r.pre_voltage_v is not None:
            self.settle(dataclasses.replace(r, pre_voltage_v=None,
                                            voltage_v=r.pre_voltage_v))
        if r.load_mode == LoadMode.POSITION:
            return self.hold_position(r.voltage_v, r.load_value)
        if r.load_mode == LoadMode.FORCE:
            return self.hold_force(r.voltage_v, r.load_value)
        return self.hold_force(r.voltage_v, 0.0)

    def dc_gain(self, contraction_m: float, u0_v: float, u1_v: float) -> tuple[float, float]:
        """(F at u0, (F(u1) - F(u0)) / (u1 - u0)) of a settled step at held x: N, N/V."""
        f0 = self.hold_position(u0_v, contraction_m).force_n
        f1 = self.hold_position(u1_v, contraction_m).force_n
        return f0, (f1 - f0) / (u1_v - u0_v)

    def step_response(self, contraction_m: float, u0_v: float, u1_v: float, record_s: float,
                      period_s: float) -> np.ndarray:
        """Force samples (N), shape (round(record_s / period_s),), of a valve step u0 -> u1 at
        held encoder x, from the settled state at u0: the valve's pressure loop integrated
        exactly (ZOH) at the sample period, the muscle with its friction evaluated at every
        sample, the belt stretch from the previous sample, no noise, an ideal position hold.
        """
        self.hold_position(u0_v, contraction_m)
        self.valve.reset(self.p)
        n = int(round(record_s / period_s))
        out = np.empty(n)
        f = self.muscle.step(self.p, self.x_t).force_n
        for k in range(n):
            out[k] = f
            p = self.valve.step(u1_v, period_s, self.muscle.volume(self.x_t))
            x_t = contraction_m + f / self.k_b
            f = self.muscle.step(p, x_t).force_n
            self.p, self.x_t = p, x_t
        return out

    def pressure_dynamics(self, contraction_m: float) -> tuple[float, float]:
        """(b, c) of the linear pressure loop at the chamber volume of x: 1/s, 1/s^2.

        Order 2: b = 2 zeta w(V), c = w(V)^2; order 1: a first-order lag has no c, returned
        as (1/tau, 0); order 0: (0, 0)."""
        if self.valve.p.order == 0:
            return 0.0, 0.0
        if self.valve.p.order == 1:
            return 1.0 / self.valve.p.time_constant_s, 0.0
        w = self.valve.natural_frequency(self.muscle.volume(contraction_m))
        return 2.0 * self.valve.p.damping_ratio * w, w * w
