"""Proportional pressure servo valve feeding one muscle (Hoerbiger Tecno Plus, 004 section 2.1).

Steady state (004 section 2.1): p_ss = k_v * clamp(u, 0, 10 V), k_v = 0.1 MPa/V = 1e5 Pa/V.

Pressure-regulation dynamics, by ``order``:
  0: p = p_ss (static)
  1: tau p' + p = p_ss
  2: p'' + 2 zeta w p' + w^2 p = w^2 p_ss   (004 section 2.3 finds the force step response at
     fixed x 2nd order and oscillating; F is affine in p at fixed x, so p carries that order)

The regulator fills the chamber volume V_t = V_line + V_muscle(x). Pneumatic capacitance grows
with volume, so the loop's natural frequency falls as w = w_ref * sqrt(V_ref / V_t) (with
``volume_scaling``); this makes the identified b(x), c(x) of 004 Eq. 2 depend on x.

Within a step u and V are held, so the dynamics are linear time-invariant and are integrated
exactly with the ZOH matrix exponential (``pam_bench.models.lti``; ``scheme: zoh``, the
default). ``rk4`` and ``euler`` take one explicit step per exchange instead; they exist for
the work-precision benchmark (explicit Euler is unstable beyond h = 2 zeta / w). The reported
gauge pressure is clamped to [0, p_max] (the valve cannot go below atmosphere nor above its
1 MPa range).
Units: u in V, p in Pa gauge, t in s, V in m^3.
"""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np

from pam_bench.models import jit
from pam_bench.models.errors import ModelError
from pam_bench.models.lti import ZohCache, zoh_run
from pam_bench.vocabulary.params import field

__all__ = ['ValveParams', 'ValveModel', 'VolumeEvidence', 'volume_report', 'scaled_frequency',
           'transient_request', 'steady_target', 'loop_entries']


@dataclasses.dataclass
class ValveParams:
    """Parameters of ``ValveModel``."""

    gain_pa_per_v: float = field(1.0e5, 'Pa/V', 'steady-state gain k_v (004: 0.1 MPa/V)',
                                 0.0, 1.0e6)
    voltage_max_v: float = field(10.0, 'V', 'upper end of the control range', 0.0, 100.0)
    pressure_max_pa: float = field(1.0e6, 'Pa', 'largest gauge output pressure', 0.0, 1.0e7)
    order: int = field(2, '-', 'pressure dynamics order: 0 static, 1 first, 2 second', 0, 2)
    natural_frequency_rad_s: float = field(
        31.4, 'rad/s', 'natural frequency w_ref of the pressure loop at reference volume',
        0.1, 1.0e5)
    damping_ratio: float = field(0.30, '-', 'damping ratio zeta of the pressure loop',
                                 0.0, 100.0)
    time_constant_s: float = field(0.03, 's', 'time constant tau for order 1', 1.0e-6, 100.0)
    volume_scaling: bool = field(True, '-', 'scale w with sqrt(V_ref / V_total)')
    line_volume_m3: float = field(2.0e-5, 'm^3', 'volume of the line and fittings', 0.0, 1.0)
    reference_volume_m3: float = field(1.3e-4, 'm^3', 'total volume V_ref at which w = w_ref',
                                       1.0e-9, 1.0)
    scheme: str = field('zoh', '-', 'integration: zoh (exact), rk4 or euler (one step each)',
                        choices=('zoh', 'rk4', 'euler'))
    transient_step_s: float = field(0.1, 's', 'longest exchange step asked for while the '
                                    'pressure is in transient, until the chamber volume is '
                                    'seen still', 1.0e-5, 10.0)
    settled_tolerance_pa: float = field(2000.0, 'Pa', 'the pressure counts as settled within '
                                        'this of its steady state', 0.0, 1.0e6)
    volume_rate_tolerance_per_s: float = field(0.01, '1/s', 'relative rate of change of the '
                                               'chamber volume that counts as moving',
                                               0.0, 1.0e3)


def volume_report(t0_s: float, v0_m3: float, command_t_s: float, t_s: float,
                  volume_m3: float) -> tuple[float, float]:
    """What a volume report V (m^3, > 0) at ``t_s`` tells after the one before, (t0 s, V0):
    (|V - V0| / V, the time between them, or 0 when the one before came before the last
    command change at ``command_t_s``: the transient that change started is not seen yet)."""
    return (abs(volume_m3 - v0_m3) / volume_m3,
            t_s - t0_s if t0_s >= command_t_s - 1e-12 else 0.0)


def scaled_frequency(w0_rad_s: float, line_m3: float, reference_m3: float,
                     chamber_m3: float) -> float:
    """The loop's natural frequency at a chamber volume, rad/s: w0 sqrt(V_ref / (V_line + V)),
    the volume at least 0 and the sum at least 1e-12 m^3 (``ValveParams.volume_scaling``)."""
    total = line_m3 + max(chamber_m3, 0.0)
    return w0_rad_s * math.sqrt(reference_m3 / max(total, 1.0e-12))


def steady_target(gain_pa_per_v: float, voltage_max_v: float, voltage_v: float) -> float:
    """p_ss(u) = k_v u, Pa, with u clamped to [0, u_max] V (``ValveModel.steady_pressure``)."""
    u = min(max(voltage_v, 0.0), voltage_max_v)
    return gain_pa_per_v * u


def loop_entries(order: float, time_constant_s: float, damping_ratio: float, w_rad_s: float
                 ) -> tuple[float, float, float, float, float, float]:
    """The entries (A00, A01, A10, A11, B0, B1) of ``ValveModel.matrices`` as floats: order 1
    a lag of ``time_constant_s``, else the second-order loop at ``w_rad_s``."""
    if order == 1:
        k = 1.0 / time_constant_s
        return -k, 0.0, 0.0, 0.0, k, 0.0
    return 0.0, 1.0, -w_rad_s * w_rad_s, -2.0 * damping_ratio * w_rad_s, 0.0, w_rad_s * w_rad_s


def transient_request(span_s: float, change_rel: float, p_pa: float, dp_pa_s: float,
                      target_pa: float, w_rad_s: float, transient_step_s: float,
                      rate_tolerance_per_s: float, settled_pa: float) -> float:
    """``ValveModel.max_step`` for a valve of order 1 or 2 in floats: ``transient_step_s``
    while the pressure (p Pa, p' Pa/s) is farther than ``settled_pa`` from its target (or p'
    above ``settled_pa`` w) and no exchange of at least that length since the last command
    change showed the volume still (relative change over ``span_s`` at most
    ``rate_tolerance_per_s`` span); else 0 (any)."""
    if span_s >= transient_step_s - 1e-9 and change_rel <= rate_tolerance_per_s * span_s:
        return 0.0
    if abs(p_pa - target_pa) > settled_pa or abs(dp_pa_s) > settled_pa * w_rad_s:
        return transient_step_s
    return 0.0


class VolumeEvidence:
    """What a valve knows of the chamber volume's motion: the muscle's volume reports (one per
    exchange, each arriving an exchange late) and the times of its own command changes.

    ``change_rel`` is |V_k - V_k-1| / V_k between the last two reports, ``span_s`` the time
    between them when both came after the last command change (else 0: nothing is known yet of
    the transient that change started).
    """

    def __init__(self) -> None:
        self._last: tuple[float, float] | None = None     # (t s, V m^3) of the last report
        self._command_t = -math.inf
        self.change_rel = 0.0
        self.span_s = 0.0

    def command_changed(self, t_s: float) -> None:
        """The command changed at sim time ``t_s`` (the start of the exchange it acts in): what
        was known of the volume no longer counts."""
        self._command_t = t_s
        self.span_s = 0.0

    def volume(self, t_s: float, volume_m3: float) -> None:
        """A volume report stamped ``t_s``, m^3 (``volume_report``)."""
        if self._last is not None and volume_m3 > 0.0:
            self.change_rel, self.span_s = volume_report(*self._last, self._command_t, t_s,
                                                         volume_m3)
        self._last = (t_s, volume_m3)


class ValveModel:
    """Valve pressure dynamics; ``step`` advances the state exactly over one held step."""

    def __init__(self, params: ValveParams | None = None) -> None:
        self.p = params or ValveParams()
        self.state = np.zeros(2)  # (p, p') in Pa, Pa/s
        self._cache = ZohCache()

    def reset(self, pressure_pa: float = 0.0) -> None:
        """Set the valve at rest at ``pressure_pa`` gauge."""
        self.state[:] = (pressure_pa, 0.0)

    def steady_pressure(self, voltage_v: float) -> float:
        """p_ss(u) in Pa for a (clamped) control voltage in V."""
        return steady_target(self.p.gain_pa_per_v, self.p.voltage_max_v, voltage_v)

    def natural_frequency(self, chamber_volume_m3: float | None) -> float:
        """W in rad/s for the given muscle chamber volume (None: reference volume)."""
        if self.p.volume_scaling and chamber_volume_m3 is not None:
            return scaled_frequency(self.p.natural_frequency_rad_s, self.p.line_volume_m3,
                                    self.p.reference_volume_m3, chamber_volume_m3)
        return self.p.natural_frequency_rad_s

    def matrices(self, chamber_volume_m3: float | None) -> tuple[np.ndarray, np.ndarray]:
        """Continuous (A, B) with state (p, p') and input p_ss; shapes (2, 2), (2, 1)."""
        if self.p.order == 1:
            return (np.array([[-1.0 / self.p.time_constant_s, 0.0], [0.0, 0.0]]),
                    np.array([[1.0 / self.p.time_constant_s], [0.0]]))
        w = self.natural_frequency(chamber_volume_m3)
        return (np.array([[0.0, 1.0], [-w * w, -2.0 * self.p.damping_ratio * w]]),
                np.array([[0.0], [w * w]]))

    def step(self, voltage_v: float, dt_s: float, chamber_volume_m3: float | None = None
             ) -> float:
        """Advance by ``dt_s`` with ``voltage_v`` held; return the gauge output pressure, Pa.

        Raises:
            ModelError: the voltage or the step is not a finite number, or the step is < 0.
        """
        if not math.isfinite(voltage_v):
            raise ModelError(f'valve voltage {voltage_v!r} is not finite')
        if not math.isfinite(dt_s) or dt_s < 0.0:
            raise ModelError(f'valve step {dt_s!r} s is not a finite non-negative number')
        target = self.steady_pressure(voltage_v)
        if self.p.order == 0 or dt_s == 0.0:
            if self.p.order == 0:
                self.state[:] = (target, 0.0)
            return self.pressure
        a, b = self.matrices(chamber_volume_m3)
        if self.p.scheme == 'zoh':
            key = (self.p.order, round(self.natural_frequency(chamber_volume_m3), 9))
            ad, bd = self._cache.get(key, a, b, dt_s)
            self.state = ad @ self.state + bd[:, 0] * target
        elif self.p.scheme in ('rk4', 'euler'):
            def f(s: np.ndarray) -> np.ndarray:
                return a @ s + b[:, 0] * target
            s, h = self.state, dt_s
            if self.p.scheme == 'euler':
                self.state = s + h * f(s)
            else:
                k1 = f(s)
                k2 = f(s + 0.5 * h * k1)
                k3 = f(s + 0.5 * h * k2)
                k4 = f(s + h * k3)
                self.state = s + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        else:
            raise ModelError(f'valve scheme {self.p.scheme!r}: use zoh, rk4 or euler')
        return self.pressure

    def samples(self, voltage_v: float, steps_s: list[float],
                chamber_volume_m3: float | None = None) -> list[float]:
        """Advance over consecutive sub-steps (lengths in s) with u and V held; return the
        gauge pressure at the end of each, Pa, shape (n,). With ``scheme: zoh`` every sample
        is the exact ZOH update, computed once per distinct sub-step length.

        Raises:
            ModelError: the voltage or a sub-step is not finite, or a sub-step is < 0.
        """
        if self.p.order == 0 or self.p.scheme != 'zoh' or not math.isfinite(voltage_v):
            return [self.step(voltage_v, d, chamber_volume_m3) for d in steps_s]
        target = self.steady_pressure(voltage_v)
        w = self.natural_frequency(chamber_volume_m3)
        key = (self.p.order, round(w, 9))
        s0, s1 = float(self.state[0]), float(self.state[1])
        p_max = self.p.pressure_max_pa
        entries = loop_entries(self.p.order, self.p.time_constant_s, self.p.damping_ratio, w)
        if jit.wanted(len(steps_s)):
            return self._samples_compiled(steps_s, target, entries, key, s0, s1)
        out = []
        cur = None
        for d in steps_s:
            if d != cur:
                if not (math.isfinite(d) and d >= 0.0):
                    raise ModelError(f'valve step {d!r} s is not a finite non-negative number')
                a00, a01, a10, a11, b0, b1 = self._cache.get_2x2(key, *entries, d)
                b0, b1 = b0 * target, b1 * target
                cur = d
            s0, s1 = a00 * s0 + a01 * s1 + b0, a10 * s0 + a11 * s1 + b1
            out.append(min(max(s0, 0.0), p_max))
        self.state = np.array([s0, s1])
        return out

    def _samples_compiled(self, steps_s: list[float], target: float,
                          entries: tuple[float, float, float, float, float, float],
                          key: tuple[int, float], s0: float, s1: float) -> list[float]:
        """``samples`` on the compiled core: each run of equal sub-steps in one call of
        ``models.lti.zoh_run`` (the same operations, bit-equal). The runs are found by
        ``itertools.groupby``, whose loop is in C: a second of 1 ms sub-steps is one run."""
        out = np.empty(len(steps_s))
        i = 0
        for d, run in itertools.groupby(steps_s):
            if not (math.isfinite(d) and d >= 0.0):
                raise ModelError(f'valve step {d!r} s is not a finite non-negative number')
            m = len(list(run))
            a00, a01, a10, a11, b0, b1 = self._cache.get_2x2(key, *entries, d)
            s0, s1 = zoh_run(s0, s1, a00, a01, a10, a11, b0 * target, b1 * target, m,
                             self.p.pressure_max_pa, out, i)
            i += m
        self.state = np.array([s0, s1])
        return out.tolist()

    def max_step(self, voltage_v: float, evidence: VolumeEvidence) -> float:
        """Longest next exchange step this valve asks for, s (0: any).

        The valve integrates an exchange with the chamber volume of its start (the muscle
        reports the volume once per exchange), so while the pressure is in transient it asks
        for ``transient_step_s`` until an exchange of at least that length since its last
        command change showed the volume standing still (at a held length any step is exact;
        a light muscle contracts under the new pressure and its volume moves).
        """
        if self.p.order == 0:
            return 0.0
        w = self.natural_frequency(None) if self.p.order == 2 else 1.0 / self.p.time_constant_s
        return transient_request(evidence.span_s, evidence.change_rel,
                                 float(self.state[0]), float(self.state[1]),
                                 self.steady_pressure(voltage_v), w, self.p.transient_step_s,
                                 self.p.volume_rate_tolerance_per_s,
                                 self.p.settled_tolerance_pa)

    @property
    def pressure(self) -> float:
        """Gauge output pressure, Pa, clamped to [0, p_max]."""
        return min(max(float(self.state[0]), 0.0), self.p.pressure_max_pa)
