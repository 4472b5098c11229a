"""Torque servo of 004 section 3: two antagonistic muscles on a toothed-belt pulley, each driven
by an inverse model plus a PID on its own force.

Geometry (pulley pitch radius r, m; angle theta, rad; both muscles mounted at the rest
contraction x0 when theta = 0):

    M = r (F1 - F2)                 (N m; positive when muscle 1 pulls harder)
    x1 = x0 + r theta,  x2 = x0 - r theta

Force split with pretension (keeps both muscles taut: a muscle cannot push, and a slack one
loses its force control): with the base force F_b = max(F_p, F_min + |M*| / (2 r)),

    F1* = F_b + M* / (2 r),   F2* = F_b - M* / (2 r)      so both >= F_min and r (F1* - F2*) = M*

Per muscle i the valve voltage is u_i = u_ff,i + u_pid,i, clamped to [u_min, u_max]:

- ``dynamic``: u_ff from the identified inverse of 004 Eq. 2,
  u_ff = u0 + (F*'' + b(x) F*' + c(x) (F* - F_a0(x))) / d(x)   (``pam_bench.control.inverse``)
- ``static``:  u_ff = (F* - F0(x)) / k(x)   (isometric surface, no dynamics)
- ``pid``:     u_ff = 0
- a plug-in (``control.plugins``): a lab's own law per channel, the same inputs;
- PID on e = F* - F_measured (N -> V): u_pid = K_p e + K_i int(e) + K_d D, with the derivative
  filtered, D' = (e' - D) / T_f (exact ZOH of the first-order filter), and anti-windup by
  conditional integration (the integral stops while the output is clamped and the error would
  push it further).
"""

from __future__ import annotations

import dataclasses
import enum
import math
from typing import Any

from pam_bench.control.inverse import InverseModel
from pam_bench.control.params import TorqueServoParams
from pam_bench.control.plugins import PluginFault, call, controller_class
from pam_bench.models.errors import ModelError

__all__ = ['ServoMode', 'SignalKind', 'Signal', 'split_torque', 'Pid', 'TorqueServoParams',
           'ChannelOutput', 'TorqueServoController']


class ServoMode(enum.Enum):
    """Feed-forward of each muscle channel."""

    DYNAMIC = 'dynamic_inverse_pid'
    STATIC = 'static_inverse_pid'
    PID = 'pid'
    DYNAMIC_ONLY = 'dynamic_inverse'     # 004 Fig. 17: the inverse model alone, no PID
    STATIC_ONLY = 'static_inverse'

    @property
    def uses_pid(self) -> bool:
        """Whether the PID on the force error adds to the feed-forward."""
        return self not in (ServoMode.DYNAMIC_ONLY, ServoMode.STATIC_ONLY)


class SignalKind(enum.Enum):
    """Set-point waveforms of the 004 tests."""

    CONSTANT = 'constant'
    SINE = 'sine'
    SQUARE = 'square'


@dataclasses.dataclass(frozen=True)
class Signal:
    """s(t) = offset + amplitude w(t); w = sin(omega t) or sign(sin(2 pi t / period)).

    ``value_and_rates`` returns (s, s', s''); the square wave's rates are 0 (its jumps are
    left to the PID, as on the real bench)."""

    kind: SignalKind
    amplitude: float
    omega_rad_s: float = 1.0
    offset: float = 0.0
    period_s: float = 3.0

    def value_and_rates(self, t_s: float) -> tuple[float, float, float]:
        """The set point and its first and second time derivatives at ``t_s`` (s)."""
        a, w = self.amplitude, self.omega_rad_s
        if self.kind == SignalKind.SINE:
            return (self.offset + a * math.sin(w * t_s), a * w * math.cos(w * t_s),
                    -a * w * w * math.sin(w * t_s))
        if self.kind == SignalKind.SQUARE:
            phase = (t_s % self.period_s) / self.period_s
            return self.offset + (a if phase < 0.5 else -a), 0.0, 0.0
        return self.offset, 0.0, 0.0


def split_torque(torque_nm: float, rate: float, accel: float, radius_m: float,
                 pretension_n: float, min_force_n: float
                 ) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """((F1*, F1*', F1*''), (F2*, F2*', F2*'')) for M*, M*', M*'' (see the module docstring)."""
    half = 1.0 / (2.0 * radius_m)
    need = min_force_n + abs(torque_nm) * half
    if need > pretension_n:
        sgn = 1.0 if torque_nm >= 0.0 else -1.0
        base = (need, sgn * rate * half, sgn * accel * half)
    else:
        base = (pretension_n, 0.0, 0.0)
    m = (torque_nm * half, rate * half, accel * half)
    return ((base[0] + m[0], base[1] + m[1], base[2] + m[2]),
            (base[0] - m[0], base[1] - m[1], base[2] - m[2]))


class Pid:
    """PID with filtered derivative and conditional-integration anti-windup (module docstring).

    Args:
        kp: V/N. ki: V/(N s). kd: V s/N. filter_s: derivative filter time constant T_f, s.
        out_min, out_max: clamp of the controller's total output, V (used for anti-windup).
    """

    def __init__(self, kp: float, ki: float, kd: float, filter_s: float, out_min: float,
                 out_max: float) -> None:
        if filter_s <= 0.0:
            raise ModelError('PID derivative filter time constant must be > 0')
        self.kp, self.ki, self.kd, self.tf = kp, ki, kd, filter_s
        self.out_min, self.out_max = out_min, out_max
        self.integral = 0.0
        self.deriv = 0.0
        self.prev_e: float | None = None

    def reset(self) -> None:
        """Clear the integral and the derivative filter."""
        self.integral, self.deriv, self.prev_e = 0.0, 0.0, None

    def step(self, error: float, dt_s: float, feedforward: float = 0.0) -> float:
        """PID part of the output for this error (N) over dt_s (s), V."""
        if dt_s > 0.0 and self.prev_e is not None:
            raw = (error - self.prev_e) / dt_s
            a = math.exp(-dt_s / self.tf)
            self.deriv = a * self.deriv + (1.0 - a) * raw
        self.prev_e = error
        trial = self.integral + error * dt_s
        out = self.kp * error + self.ki * trial + self.kd * self.deriv
        total = feedforward + out
        windup = ((total > self.out_max and error > 0.0)
                  or (total < self.out_min and error < 0.0))
        if not windup:
            self.integral = trial
        return self.kp * error + self.ki * self.integral + self.kd * self.deriv


@dataclasses.dataclass(frozen=True)
class ChannelOutput:
    """One muscle channel after a control step: N, m, V."""

    force_setpoint_n: float
    contraction_m: float
    u_feedforward_v: float
    u_pid_v: float
    voltage_v: float


class TorqueServoController:
    """Force split, inverse model and PID for one or two muscles (module docstring).

    With ``muscles = 1`` the set point is muscle 1's force (N) and x1 = x0 + r theta; this is
    the single-muscle force check of 004 section 3.1.
    """

    def __init__(self, params: TorqueServoParams, mode: ServoMode | str,
                 inverse: InverseModel | None, muscles: int = 2,
                 plugin_settings: Any = None) -> None:
        if muscles not in (1, 2):
            raise ModelError('muscles must be 1 or 2')
        self.plugin: list[Any] = []
        if isinstance(mode, str) and mode not in {m.value for m in ServoMode}:
            cls = controller_class(mode)
            if cls is None:
                raise ModelError(f'unknown controller {mode!r} (neither built in nor an '
                                 'installed plug-in: pam-bench plugins lists them)')
            settings = plugin_settings if plugin_settings is not None else cls.settings()
            try:
                self.plugin = [cls(settings, params, inverse) for _ in range(muscles)]
            except Exception as exc:  # noqa: BLE001 - a lab's code, named
                raise PluginFault(f'controller plug-in {mode!r} cannot be built: '
                                  f'{type(exc).__name__}: {exc}') from None
            self.name = mode
            mode = ServoMode.PID
        else:
            mode = ServoMode(mode)
            self.name = mode.value
            if mode != ServoMode.PID and inverse is None:
                raise ModelError(f'{mode.value} needs an inverse model file')
        self.p, self.mode, self.inverse, self.muscles = params, mode, inverse, muscles
        self.r = params.pitch_diameter_m / 2.0
        self.pids = [Pid(params.kp_v_per_n, params.ki_v_per_n_s, params.kd_v_s_per_n,
                         params.derivative_filter_s, params.voltage_min_v,
                         params.voltage_max_v) for _ in range(muscles)]

    def retune(self, params: TorqueServoParams) -> None:
        """Take new PID gains and derivative filter (the tunable ones) between two steps,
        bumpless in the integral term: each channel's integral of the error is rescaled by
        k_i,old / k_i,new so that k_i times it keeps its value (the proportional and derivative
        terms change with their gains)."""
        self.p = params
        for pid in self.pids:
            if pid.ki > 0.0 and params.ki_v_per_n_s > 0.0:
                pid.integral *= pid.ki / params.ki_v_per_n_s
            pid.kp, pid.ki, pid.kd = params.kp_v_per_n, params.ki_v_per_n_s, params.kd_v_s_per_n
            pid.tf = params.derivative_filter_s

    def clamp_torque(self, torque_nm: float) -> tuple[float, bool]:
        """(M* within +-max_torque, whether it was clamped)."""
        m = self.p.max_torque_nm
        return min(max(torque_nm, -m), m), abs(torque_nm) > m

    def reset(self) -> None:
        """Reset every channel's PID (or plug-in)."""
        for pid in self.pids:
            pid.reset()
        for ctl in self.plugin:
            try:
                ctl.reset()
            except Exception:  # noqa: BLE001 - its next step says what is wrong
                pass

    def _feedforward(self, f: tuple[float, float, float], x: float) -> float:
        """The built-in feed-forward of the channel: the inverse model, dynamic or static."""
        if self.inverse is None or self.mode == ServoMode.PID:
            return 0.0
        if self.mode in (ServoMode.DYNAMIC, ServoMode.DYNAMIC_ONLY):
            return self.inverse.dynamic_voltage(f[0], f[1], f[2], x)
        return self.inverse.static_voltage(f[0], x)

    def step(self, dt_s: float, setpoint: tuple[float, float, float], angle_rad: float,
             forces_n: tuple[float, ...]) -> list[ChannelOutput]:
        """One control period.

        Args:
            dt_s: period, s.
            setpoint: (M*, M*', M*'') in N m, N m/s, N m/s^2 (muscles = 2, already clamped),
                or (F*, F*', F*'') in N... for muscles = 1.
            angle_rad: measured pulley angle.
            forces_n: measured forces, shape (muscles,).
        """
        targets: tuple[tuple[float, float, float], ...]
        xs: tuple[float, ...]
        if self.muscles == 2:
            targets = split_torque(*setpoint, self.r, self.p.pretension_n, self.p.min_force_n)
            xs = (self.p.rest_contraction_m + self.r * angle_rad,
                  self.p.rest_contraction_m - self.r * angle_rad)
        else:
            targets = (setpoint,)
            xs = (self.p.rest_contraction_m + self.r * angle_rad,)
        out = []
        for i, (f, x, meas, pid) in enumerate(zip(targets, xs, forces_n, self.pids,
                                                  strict=True)):
            if self.plugin:
                ff, u_pid = call(self.name, self.plugin[i], dt_s, f, x, meas)
                u = min(max(ff + u_pid, self.p.voltage_min_v), self.p.voltage_max_v)
                out.append(ChannelOutput(f[0], x, ff, u_pid, u))
                continue
            ff = self._feedforward(f, x)
            u_pid = pid.step(f[0] - meas, dt_s, ff) if self.mode.uses_pid else 0.0
            u = min(max(ff + u_pid, self.p.voltage_min_v), self.p.voltage_max_v)
            out.append(ChannelOutput(f[0], x, ff, u_pid, u))
        return out
