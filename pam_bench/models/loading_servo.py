"""Electric loading servo of the 004 bench: motor, planetary gear, backlash, belt and pulley.

Figures (004 section 2.1): motor rated torque 1.27 N m, planetary ratio i = 70, backlash at
most 9 arcmin, toothed belt on a pulley of pitch diameter 63.66 mm (r = 31.83 mm); the largest
force on the muscle is i * 1.27 / r = 2792 N.

Mechanics (angles at the gear output, rad; forces N; torques N m):

    J phi'' = r F(x) - tau - c phi'                            (gear output, reflected inertia J)
    theta   = phi + beta(F),  beta = (b_l / 2) clip(F / F_bl, -1, 1)   (pulley inside the play)
    x       = r theta + F / k_b                                 (muscle end, belt stretch)

The muscle always pulls, so the pulley rests on the contraction side of the play; the clip
with the small force F_bl makes the change of side continuous (no chatter at F = 0).

Coupling with the muscle node over one exchange step: the muscle publishes F_k, its stiffness
K_k = -dF/dx and the contraction x_e it was evaluated at; inside the step
F(x) = max(0, F_k - K_k (x - x_e)). That makes the coupling implicit in the stiffness, stable for
exchange steps far longer than sqrt(J / (K r^2)).

Drive controller (torque tau at the output, clamped to +-tau_max = min(i T_rated, F_max r)).
Proportional and derivative parts act on the force or position the drive would sample at 1 kHz
between exchanges (the linearisation above, noise-free); the integral acts on the last
measured sensor value propagated the same way, so the steady state is the one the load cell or
the encoder reads:
  force    (004: PID on the strain-gauge force), e = F* - F:
           tau = r [F* + K_p e + K_i I + K_d K x'],  I' = F* - (F + e_F)
           while the last reading is within the band |F* - F_m| <= F_band, else I' = 0
           (integral separation, decided once per exchange as a digital drive decides per
           sample: a slack muscle or the overshoot on taking up the slack at full speed must
           not wind the integral up, or the drive runs away and cycles)
  position (PID on the pulley), gear angle phi tracks x* / r, the integral removes play and
           belt stretch as the encoder sees them:
           tau = r [F + K_px (r phi - x*) + K_dx r phi' + K_ix I],
           I' = r (phi + beta + e_th) - x*
  off:     tau = 0
where e_F = F_m - F_prev and e_th = theta_m - theta_prev are the errors of the last readings
(noise, quantisation) against the true values at the instant each was taken.

With F and tau inside their limits the step is affine in s = (phi, phi', I, 1) and is integrated
exactly, s(t + h) = expm(M h) s(t) (``scheme: zoh``, default). Where a limit is reached the step
is redone with classical RK4 (or explicit Euler) on internal steps short enough for stability.
The drive limits the output speed to w_max (motor 3000 rpm / i) and the integral to
|gain * I| <= 25 % of F_max (anti-windup). The belt travel ends at hard stops x_min, x_max
(inelastic: the pulley stops there).
"""

from __future__ import annotations

import dataclasses
import enum
import math

import numpy as np
from scipy.linalg import expm

from pam_bench.models.errors import ModelError
from pam_bench.models.params import field

__all__ = ['LoadMode', 'LoadingServoParams', 'LoadingServoModel', 'ServoOutput']


class LoadMode(enum.IntEnum):
    """Modes of the loading servo (values match LoadCommand.MODE_*)."""

    OFF = 0
    FORCE = 1
    POSITION = 2


@dataclasses.dataclass
class LoadingServoParams:
    """Parameters of ``LoadingServoModel``."""

    pitch_diameter_m: float = field(0.06366, 'm', 'pulley pitch diameter (004)', 0.001, 10.0)
    rated_torque_nm: float = field(1.27, 'N m', 'motor rated torque (004)', 0.0, 1.0e4)
    gear_ratio: float = field(70.0, '-', 'planetary gear ratio i (004)', 1.0, 1.0e4)
    force_limit_n: float = field(2792.0, 'N', 'largest force on the muscle (004)', 0.0, 1.0e6)
    backlash_arcmin: float = field(9.0, 'arcmin', 'gear backlash b_l (004: at most 9)',
                                   0.0, 600.0)
    backlash_force_n: float = field(5.0, 'N', 'force F_bl over which the play is taken up',
                                    1.0e-3, 1.0e4)
    inertia_kg_m2: float = field(0.15, 'kg m^2', 'inertia J reflected to the gear output',
                                 1.0e-6, 1.0e3)
    damping_nm_s_per_rad: float = field(0.5, 'N m s/rad', 'viscous damping c at the output',
                                        0.0, 1.0e4)
    belt_stiffness_n_per_m: float = field(2.0e6, 'N/m', 'belt and load-cell stiffness k_b',
                                          1.0e2, 1.0e12)
    travel_min_m: float = field(-0.05, 'm', 'end stop of the belt travel (stretch side)',
                                -10.0, 0.0)
    travel_max_m: float = field(0.16, 'm', 'end stop of the belt travel (contraction side)',
                                0.0, 10.0)
    speed_limit_rad_s: float = field(4.49, 'rad/s', 'output speed limit w_max (3000 rpm / i)',
                                     1.0e-3, 1.0e4)
    transient_step_s: float = field(0.02, 's', 'longest exchange step asked for while the '
                                    'drive moves', 1.0e-5, 10.0)
    settled_speed_m_s: float = field(2.0e-4, 'm/s', 'the drive counts as settled below this '
                                     'belt speed', 0.0, 10.0)
    settled_force_n: float = field(2.0, 'N', 'in force mode the drive counts as settled only '
                                   'within this of its set value (load cell)', 0.0, 1.0e4)
    dynamics: bool = field(True, '-', 'simulate the drive mechanics; false: ideal set value')
    scheme: str = field('zoh', '-', 'integration scheme: zoh (exact), rk4 or euler')
    internal_step_s: float = field(1.0e-3, 's', 'longest internal integration step',
                                   1.0e-6, 1.0)
    force_kp: float = field(5.0, '-', 'force loop proportional gain K_p', 0.0, 1.0e4)
    force_ki_per_s: float = field(12.0, '1/s', 'force loop integral gain K_i', 0.0, 1.0e6)
    force_kd_s: float = field(1.8, 's', 'force loop derivative gain K_d', 0.0, 1.0e4)
    force_integral_band_n: float = field(25.0, 'N', 'force loop integrates only while the '
                                         'load cell is within this of the set value', 0.0,
                                         1.0e6)
    position_kp_n_per_m: float = field(2.0e6, 'N/m', 'position loop gain K_px', 0.0, 1.0e10)
    position_ki_n_per_m_s: float = field(1.0e7, 'N/(m s)', 'position loop integral K_ix',
                                         0.0, 1.0e12)
    position_kd_n_s_per_m: float = field(3.0e4, 'N s/m', 'position loop derivative K_dx',
                                         0.0, 1.0e9)


@dataclasses.dataclass
class ServoOutput:
    """Result of one exchange step."""

    pulley_angle_rad: float
    pulley_rate_rad_s: float
    contraction_m: float
    output_torque_nm: float
    saturated: bool


class LoadingServoModel:
    """Loading servo drive and belt mechanics; ``step`` advances one exchange step."""

    def __init__(self, params: LoadingServoParams | None = None) -> None:
        self.p = params or LoadingServoParams()
        if self.p.scheme not in ('zoh', 'rk4', 'euler'):
            raise ModelError(f'loading servo scheme {self.p.scheme!r}: use zoh, rk4 or euler')
        self.r = self.p.pitch_diameter_m / 2.0
        self.tau_max = min(self.p.rated_torque_nm * self.p.gear_ratio,
                           self.p.force_limit_n * self.r)
        self.half_play = math.radians(self.p.backlash_arcmin / 60.0) / 2.0
        self.mode = LoadMode.OFF
        self.setpoint = 0.0
        self.state = np.zeros(3)   # phi (rad), phi' (rad/s), integral of the error
        self.torque = 0.0
        self.force_error_n = 0.0       # set value - last load-cell reading (force mode), N
        self.saturated = False
        self.contraction = 0.0
        self.angle = 0.0
        self._prev_force = 0.0
        self._prev_angle = 0.0

    def command(self, mode: LoadMode, setpoint: float) -> None:
        """New mode and set value (N or m); the integral is reset on a mode change."""
        if not math.isfinite(setpoint):
            raise ModelError(f'loading servo set value {setpoint!r} is not finite')
        mode = LoadMode(mode)
        if mode != self.mode:
            self.state[2] = 0.0
        if mode == LoadMode.FORCE and (mode, setpoint) != (self.mode, self.setpoint):
            self.force_error_n = math.inf     # unknown until the next reading: short steps
        self.mode, self.setpoint = mode, setpoint

    def reset(self, contraction_m: float = 0.0) -> None:
        """Drive at rest with the muscle end at ``contraction_m`` and no load."""
        self.state[:] = (contraction_m / self.r, 0.0, 0.0)
        self.contraction = contraction_m
        self.angle = contraction_m / self.r

    def _play(self, force_n: float) -> float:
        return self.half_play * min(max(force_n / self.p.backlash_force_n, -1.0), 1.0)

    def _linear_system(self, f_k: float, k_m: float, x_e: float, f_meas: float,
                       th_meas: float) -> tuple[np.ndarray, float, float, float]:
        """Affine dynamics s' = M s over one step, s = (phi, phi', I, 1).

        Returns:
            (M, a_x, c0, f0): M shape (4, 4); x = a_x phi + c0; F = f0 - K a_x phi.
        """
        p, r = self.p, self.r
        kb = p.belt_stiffness_n_per_m
        den = 1.0 + k_m / kb
        a_x = r / den
        c0 = (r * self._play(f_k) + (f_k + k_m * x_e) / kb) / den
        f0 = f_k - k_m * (c0 - x_e)
        kf = k_m * a_x                       # -dF/dphi
        # tau = t_phi phi + t_w phi' + t_i I + t_1
        t_phi = t_w = t_i = t_1 = 0.0
        i_phi = i_1 = 0.0                    # I' = i_phi phi + i_1
        sp = self.setpoint
        if self.mode == LoadMode.FORCE:
            t_phi, t_w, t_i = r * p.force_kp * kf, r * p.force_kd_s * kf, r * p.force_ki_per_s
            t_1 = r * ((1.0 + p.force_kp) * sp - p.force_kp * f0)
            if abs(sp - f_meas) <= p.force_integral_band_n:
                i_phi, i_1 = kf, sp - (f_meas - self._prev_force) - f0
        elif self.mode == LoadMode.POSITION:
            t_phi = r * (-kf + p.position_kp_n_per_m * r)
            t_w, t_i = r * p.position_kd_n_s_per_m * r, r * p.position_ki_n_per_m_s
            t_1 = r * (f0 - p.position_kp_n_per_m * sp)
            i_phi, i_1 = r, r * (self._play(f_k) + th_meas - self._prev_angle) - sp
        j, c = p.inertia_kg_m2, p.damping_nm_s_per_rad
        m = np.zeros((4, 4))
        m[0, 1] = 1.0
        m[1, 0] = (-r * kf - t_phi) / j
        m[1, 1] = (-c - t_w) / j
        m[1, 2] = -t_i / j
        m[1, 3] = (r * f0 - t_1) / j
        m[2, 0], m[2, 3] = i_phi, i_1
        self._tau_row = np.array([t_phi, t_w, t_i, t_1])
        return m, a_x, c0, f0

    def step(self, dt_s: float, force_n: float, stiffness_n_per_m: float,
             evaluated_contraction_m: float, measured_force_n: float,
             measured_angle_rad: float) -> ServoOutput:
        """Advance by ``dt_s`` with the muscle linearised where it was last evaluated.

        Args:
            dt_s: exchange step, s.
            force_n: muscle tension F_k, N.
            stiffness_n_per_m: K_k = -dF/dx, N/m.
            evaluated_contraction_m: x_e at which the muscle computed F_k, m.
            measured_force_n: last load-cell reading, N.
            measured_angle_rad: last encoder reading, rad.

        Raises:
            ModelError: an input is not finite, or the state diverged.
        """
        vals = (dt_s, force_n, stiffness_n_per_m, evaluated_contraction_m, measured_force_n,
                measured_angle_rad)
        self.force_error_n = (self.setpoint - measured_force_n
                              if self.mode == LoadMode.FORCE else 0.0)
        if not all(math.isfinite(v) for v in vals) or dt_s < 0.0:
            raise ModelError(f'loading servo inputs not finite or negative step: {vals!r}')
        k_m = max(stiffness_n_per_m, 0.0)
        if not self.p.dynamics:
            return self._ideal(force_n, k_m, evaluated_contraction_m)
        m, a_x, c0, f0 = self._linear_system(force_n, k_m, evaluated_contraction_m,
                                             measured_force_n, measured_angle_rad)
        s0 = np.append(self.state, 1.0)
        s = None
        if self.p.scheme == 'zoh' and dt_s > 0.0:
            s = expm(m * dt_s) @ s0
            if not (self._inside_limits(s0, f0, a_x, k_m)
                    and self._inside_limits(s, f0, a_x, k_m)):
                s = None
        if s is None:
            s = self._substeps(s0, m, dt_s, f0, a_x, k_m)
        if not np.all(np.isfinite(s)):
            raise ModelError('loading servo state diverged')
        self.state = s[:3].copy()
        self._end_stops(a_x, c0)
        s[:3] = self.state
        tau = float(self._tau_row @ s)
        self.saturated = abs(tau) > self.tau_max * (1.0 + 1e-9)
        self.torque = min(max(tau, -self.tau_max), self.tau_max)
        x = a_x * s[0] + c0
        f_end = max(f0 - k_m * a_x * s[0], 0.0)
        self._prev_force, self._prev_angle = force_n, self.angle
        self.contraction = x
        self.angle = float(s[0]) + self._play(f_end)
        return ServoOutput(self.angle, float(s[1]), x, self.torque, self.saturated)

    def max_step(self) -> float:
        """Longest next exchange step the drive asks for, s (0: any): short while the belt
        moves or (force mode) while the load cell is off the set value, so the one-step
        coupling lag stays small where the muscle is soft, slack or slipping."""
        if not self.p.dynamics or self.mode == LoadMode.OFF:
            return 0.0
        if abs(self.state[1]) * self.r > self.p.settled_speed_m_s or self.saturated:
            return self.p.transient_step_s
        # a muscle creeping through its friction looks stiff to the one-step linearisation:
        # the belt hardly moves but the force is not there yet
        if abs(self.force_error_n) > self.p.settled_force_n:
            return self.p.transient_step_s
        return 0.0

    def _end_stops(self, a_x: float, c0: float) -> None:
        x = a_x * self.state[0] + c0
        lo, hi = self.p.travel_min_m, self.p.travel_max_m
        if x < lo or x > hi:
            self.state[0] = ((lo if x < lo else hi) - c0) / a_x
            self.state[1] = 0.0

    def _inside_limits(self, s: np.ndarray, f0: float, a_x: float, k_m: float) -> bool:
        tau = float(self._tau_row @ s)
        return (abs(tau) <= self.tau_max and f0 - k_m * a_x * s[0] >= -1.0e-9
                and abs(s[1]) <= self.p.speed_limit_rad_s
                and abs(s[2]) <= self._integral_limit())

    def _integral_limit(self) -> float:
        gain = {LoadMode.FORCE: self.p.force_ki_per_s,
                LoadMode.POSITION: self.p.position_ki_n_per_m_s}.get(self.mode, 0.0)
        return 0.25 * self.p.force_limit_n / gain if gain > 0.0 else math.inf

    def _substeps(self, s0: np.ndarray, m: np.ndarray, dt_s: float, f0: float, a_x: float,
                  k_m: float) -> np.ndarray:
        """Nonlinear integration (force clamp at 0, torque limit, no wind-up when saturated)."""
        p, r = self.p, self.r
        tau_row = self._tau_row
        lam = float(np.abs(np.linalg.eigvals(m[:3, :3])).max())   # fastest rate, 1/s
        h_max = min(p.internal_step_s, 0.5 / lam if lam > 0.0 else p.internal_step_s)
        w_max, i_max = p.speed_limit_rad_s, self._integral_limit()
        n = max(1, math.ceil(dt_s / h_max - 1e-9))
        h = dt_s / n

        def deriv(s: np.ndarray) -> np.ndarray:
            lin = m @ s
            tau = float(tau_row @ s)
            f_lin = f0 - k_m * a_x * s[0]
            if abs(tau) <= self.tau_max and f_lin >= 0.0 and abs(s[1]) < w_max \
                    and abs(s[2]) < i_max:
                return lin
            tau_c = min(max(tau, -self.tau_max), self.tau_max)
            acc = (r * max(f_lin, 0.0) - tau_c - p.damping_nm_s_per_rad * s[1]) \
                / p.inertia_kg_m2
            out = lin.copy()
            if abs(s[1]) >= w_max and acc * s[1] > 0.0:
                acc = 0.0                         # the drive holds its speed limit
            out[1] = acc
            if abs(tau) > self.tau_max or (abs(s[2]) >= i_max and out[2] * s[2] > 0.0):
                out[2] = 0.0                      # conditional integration: no wind-up
            return out

        s = s0.copy()
        s[1] = min(max(s[1], -w_max), w_max)
        s[2] = min(max(s[2], -i_max), i_max)
        for _ in range(n):
            if p.scheme == 'euler':
                s = s + h * deriv(s)
            else:
                k1 = deriv(s)
                k2 = deriv(s + 0.5 * h * k1)
                k3 = deriv(s + 0.5 * h * k2)
                k4 = deriv(s + h * k3)
                s = s + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        return s

    def _ideal(self, force_n: float, k_m: float, x_e: float) -> ServoOutput:
        """No mechanics: position mode puts x at the set value; force mode moves x to the
        linearised equilibrium F(x) = F*; off keeps x."""
        x = self.contraction
        if self.mode == LoadMode.POSITION:
            x = self.setpoint
        elif self.mode == LoadMode.FORCE and k_m > 0.0:
            x = x_e + (force_n - self.setpoint) / k_m
        self.contraction = x
        self.angle = x / self.r
        self.state[:] = (self.angle, 0.0, 0.0)
        self.torque = self.r * (self.setpoint if self.mode == LoadMode.FORCE else force_n)
        self.saturated = abs(self.torque) > self.tau_max
        self.torque = min(max(self.torque, -self.tau_max), self.tau_max)
        return ServoOutput(self.angle, 0.0, x, self.torque, self.saturated)
