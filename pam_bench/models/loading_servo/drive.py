"""Electric loading servo of the 004 bench as a sub-step law: motor, gear, backlash, belt, pulley.

Figures (004 section 2.1): motor rated torque 1.27 N m, planetary ratio i = 70, backlash at
most 9 arcmin, toothed belt on a pulley of pitch diameter 63.66 mm (r = 31.83 mm); the largest
force on the muscle is i * 1.27 / r = 2792 N.

Mechanics (angles at the gear output, rad; forces N; torques N m):

    J w' = r F - tau - c w,   phi' = w                         (gear output, reflected inertia J)
    theta = phi + beta(F),  beta = (b_l / 2) clip(F / F_bl, -1, 1)   (pulley inside the play)
    x     = r theta + F / k_b                                    (muscle end, belt stretch)

The muscle always pulls, so the pulley rests on the contraction side of the play; the clip
with the small force F_bl makes the change of side continuous (no chatter at F = 0).

Drive controller (torque tau at the output, |tau| <= tau_max = min(i T_rated, F_max r)):
  force    (004: PID on the strain-gauge force), e = F* - F:
           tau = r [F* + K_p e + K_i I + K_d e'],  I' = e while |e| <= F_band, else I' = 0
           (integral separation: a slack muscle, or the overshoot on taking up the slack at
           full speed, must not wind the integral up, or the drive runs away and cycles)
  position (PID on the pulley encoder, with the load it measures compensated):
           tau = r [F + K_px (r phi - x*) + K_dx r w + K_ix I],  I' = r theta_m - x*
           (theta_m: the angle rounded to the 16-bit encoder count)
  off:     tau = 0
Limits: conditional integration (I frozen while tau is at its limit), |K I| <= 25 % of F_max
(anti-windup), |w| <= w_max (motor 3000 rpm / i), hard end stops of the belt travel
x_min <= x <= x_max (inelastic: the pulley stops there).

Sub-step law (``prepare``, ``contraction``, ``commit``). The muscle force F depends on where
the drive puts the muscle end, and the drive's torque depends on F, so the two are solved
together, sub-step by sub-step, by ``pam_bench.models.coupling``: over a sub-step d the drive
is integrated with backward (implicit) Euler, implicit in the force F_+ at the end of the
sub-step. That makes the end position an explicit, continuous, non-decreasing function
x_+ = X(F_+) of that force (``contraction``), with

    force:    I_+ = I + d e_+,   tau_+ = r [F* + K_p e_+ + K_i I_+ + K_d (e_+ - e_0) / d]
    position: I_+ = I + d (r theta_m,+ - x*),  the K_px, K_dx and K_ix terms implicit in w_+
    w_+ (1 + d c / J) = w + (d / J) (r F_+ - tau_+),  phi_+ = phi + d w_+,
    x_+ = r (phi_+ + beta(F_+)) + F_+ / k_b

then the limits (tau clipped with the integral frozen, w clipped, x held at an end stop). The
muscle solves F_+ = F_muscle(p_+, X(F_+)) and the drive keeps the sub-step with that F_+
(``commit``). Backward Euler is L-stable, so the stiff modes of the force loop (the derivative
term against a sticking braid, about 7000 1/s) stay damped at any sub-step, and the error is
first order in d (BENCHMARKS.md, 'Work-precision of the models', drive rows).

``dynamics: false`` replaces the drive by an ideal holder (``holders`` states its law). The law a
copy of the drive needs to follow the same sub-steps (the DriveLaw message) is
``models.loading_servo.law``.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from pam_bench.models import jit
from pam_bench.models.errors import ModelError
from pam_bench.models.loading_servo.params import LoadingServoParams, LoadMode
from pam_bench.models.loading_servo.substep import (
    CONTRACTION,
    ENCODER,
    FORCE,
    INTEGRAL,
    NO_PREP,
    PHI,
    SATURATED,
    STATE_SIZE,
    TORQUE,
    DriveRecord,
    Prep,
    W,
    drive_commit,
    drive_contraction_and_compliance,
    drive_play,
    drive_prepare,
    replay_drive,
)

__all__ = ['LoadingServoModel', 'ServoOutput', 'SubStep']


SubStep = Prep
"""The prepared sub-step (``Prep``): tau_+ = t0 + t1 F_+ and I_+ = i0 + i1 F_+
(unclamped), the integral's limit and gain, the position loop's rate when it fixes one."""


@dataclasses.dataclass
class ServoOutput:
    """State of the drive after a sub-step: rad, rad/s, m, N m, saturated."""

    pulley_angle_rad: float
    pulley_rate_rad_s: float
    contraction_m: float
    output_torque_nm: float
    saturated: bool


def _slot(index: int, doc: str) -> Any:
    """A property reading and writing ``state[index]``."""

    def get(self: LoadingServoModel) -> float:
        return self.state[index]

    def put(self: LoadingServoModel, value: float) -> None:
        self.state[index] = value

    return property(get, put, doc=doc)


class LoadingServoModel:
    """Loading servo drive and belt mechanics as a sub-step law (module docstring).

    The law is the compiled core's (``drive_prepare``, ``drive_end``,
    ``drive_contraction_and_compliance``, ``drive_commit``, the ideal holder of
    ``dynamics: false`` included), run here interpreted over the drive's parameters by name
    (``record``) and its state (``state``: a list indexed by ``PHI`` ...).
    """

    def __init__(self, params: LoadingServoParams | None = None) -> None:
        self.p = params or LoadingServoParams()
        p = self.p
        self.r = p.pitch_diameter_m / 2.0
        self.tau_max = min(p.rated_torque_nm * p.gear_ratio, p.force_limit_n * self.r)
        self.half_play = math.radians(p.backlash_arcmin / 60.0) / 2.0
        self.count_rad = 2.0 * math.pi / 2 ** p.encoder_bits_per_rev
        self.mode = LoadMode.OFF
        self.setpoint = 0.0
        self.record = DriveRecord(
            r=self.r, j=p.inertia_kg_m2, c=p.damping_nm_s_per_rad, tau_max=self.tau_max,
            half_play=self.half_play, count_rad=self.count_rad,
            backlash_force_n=p.backlash_force_n, belt_stiffness=p.belt_stiffness_n_per_m,
            travel_min=p.travel_min_m, travel_max=p.travel_max_m,
            speed_limit=p.speed_limit_rad_s, force_kp=p.force_kp, force_ki=p.force_ki_per_s,
            force_kd=p.force_kd_s, force_band=p.force_integral_band_n,
            position_kp=p.position_kp_n_per_m, position_ki=p.position_ki_n_per_m_s,
            position_kd=p.position_kd_n_s_per_m, force_limit=p.force_limit_n,
            dynamics=1.0 if p.dynamics else 0.0)
        # gear output angle rad, its rate rad/s, controller integral (N s or m s), muscle force
        # of the last sub-step N, its encoder reading rad, muscle end m, torque N m, saturated
        self.state: list[float] = [0.0] * STATE_SIZE
        self._prep = NO_PREP

    # --- the state by name --------------------------------------------------------------
    phi = _slot(PHI, 'Gear output angle, rad.')
    w = _slot(W, 'Gear output rate, rad/s.')
    integral = _slot(INTEGRAL, 'Controller integral, N s or m s.')
    force_n = _slot(FORCE, 'Muscle force of the last sub-step, N.')
    encoder_rad = _slot(ENCODER, 'Encoder reading of the last sub-step, rad.')
    contraction_m = _slot(CONTRACTION, 'Muscle end of the last sub-step, m.')
    torque = _slot(TORQUE, 'Output torque, N m.')

    @property
    def saturated(self) -> bool:
        """Whether the torque was at its limit in the last sub-step."""
        return self.state[SATURATED] != 0.0

    # --- commands and state -------------------------------------------------------------
    def command(self, mode: LoadMode, setpoint: float) -> None:
        """New mode and set value (N or m); the integral is reset on a mode change."""
        if not math.isfinite(setpoint):
            raise ModelError(f'loading servo set value {setpoint!r} is not finite')
        mode = LoadMode(mode)
        if mode != self.mode:
            self.integral = 0.0
        self.mode, self.setpoint = mode, float(setpoint)

    def reset(self, contraction_m: float = 0.0) -> None:
        """Drive at rest with the muscle end at ``contraction_m`` and no load."""
        self.phi = contraction_m / self.r
        self.w = self.integral = self.force_n = 0.0
        self.encoder_rad = self.quantised(self.phi)
        self.contraction_m = contraction_m

    @property
    def angle(self) -> float:
        """Pulley angle theta = phi + beta(F), rad."""
        return self.phi + self.play(self.force_n)

    # --- the sub-step law ---------------------------------------------------------------
    def prepare(self, d: float) -> None:
        """Coefficients of the sub-step of length ``d`` (s) from the kept state.

        Raises:
            ModelError: ``d`` is not finite and positive.
        """
        if not (d > 0.0 and math.isfinite(d)):
            raise ModelError(f'loading servo sub-step {d!r} s is not finite and positive')
        if self.p.dynamics:
            self._prep = drive_prepare(d, self.record, self.state, int(self.mode),
                                                self.setpoint)

    def play(self, force_n: float) -> float:
        """beta(F): where the pulley sits inside the gear play, rad."""
        return drive_play(force_n, self.record)

    def quantised(self, angle_rad: float) -> float:
        """The angle rounded to the encoder count the position loop reads, rad."""
        return round(angle_rad / self.count_rad) * self.count_rad

    def contraction(self, force_n: float) -> float:
        """X(F): where the prepared sub-step puts the muscle end if the muscle pulls with
        ``force_n`` (N) at its end, m. Continuous and non-decreasing in the force."""
        return self.contraction_and_compliance(force_n)[0]

    def contraction_and_compliance(self, force_n: float) -> tuple[float, float]:
        """(X(F) m, dX/dF m/N) of the prepared sub-step at ``force_n``: ``contraction`` and
        ``compliance`` in one evaluation (the coupled solve asks for both at every iterate)."""
        return drive_contraction_and_compliance(
            force_n, self.record, self.state, int(self.mode), self.setpoint, self._prep)

    def commit(self, force_n: float) -> None:
        """Keep the prepared sub-step with the muscle force ``force_n`` (N) at its end
        (``output`` then tells where it left the drive)."""
        drive_commit(force_n, self.record, self.state, int(self.mode), self.setpoint,
                              self._prep)

    def arrays(self) -> tuple[Any, np.ndarray]:
        """The drive as the compiled core takes it (``models.jit``): its parameters by
        name (``DriveRecord``) and its state as an array (indexed by ``PHI`` ...),
        shape (``STATE_SIZE``,)."""
        return self.record, np.array(self.state, dtype=float)

    def set_state(self, ds: np.ndarray) -> None:
        """Take the state a compiled solve or replay left (indexed by ``PHI`` ...)."""
        self.state = [float(v) for v in ds]

    def output(self) -> ServoOutput:
        """Pulley angle and rate, muscle end, torque and saturation of the kept state."""
        return ServoOutput(self.angle, self.w, self.contraction_m, self.torque, self.saturated)

    def replay(self, steps_s: list[float], forces_n: list[float]) -> ServoOutput:
        """Follow the sub-steps a coupled solve took: lengths (s) and end forces (N).

        Raises:
            ModelError: the lists are empty or of different lengths, or a value is not finite.
        """
        if not steps_s or len(steps_s) != len(forces_n):
            raise ModelError(f'drive replay needs as many forces as sub-steps, got '
                             f'{len(forces_n)} forces for {len(steps_s)} sub-steps')
        if not all(map(math.isfinite, forces_n)):
            bad = next(f for f in forces_n if not math.isfinite(f))
            raise ModelError(f'muscle force {bad!r} is not finite')
        if jit.wanted(len(steps_s)):
            steps = np.asarray(steps_s, dtype=float)
            if not (np.isfinite(steps).all() and (steps > 0.0).all()):
                bad = steps[~(np.isfinite(steps) & (steps > 0.0))][0]
                raise ModelError(f'loading servo sub-step {bad!r} s is not finite and positive')
            dp, ds = self.arrays()
            replay_drive(steps, np.asarray(forces_n, dtype=float), dp, ds,
                                  int(self.mode), float(self.setpoint))
            self.set_state(ds)
            return self.output()
        for d, f in zip(steps_s, forces_n, strict=True):
            self.prepare(d)
            self.commit(f)
        return self.output()
