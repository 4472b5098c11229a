"""McKibben muscle of the 004 bench: d_n = 20 mm, l_n = 350 mm, bladder free inside the braid.

Contraction x = l_n - l in m (x < 0 is stretch), gauge pressure p in Pa, force F in N.

Static force (quasi-static: the muscle's own mass and the gas inertia are neglected):

    F = max(0, F_bb(p, x) - F_f)                                             (never pushes)
    F_bb = g(x) (p - p_th)^+ - k_bl x + k_s (-x)^+
    g(x) = g_0 (1 - x / x_z)^n  for x < x_z, else 0

- g(x) (N/Pa) is the isometric gain dF/dp at contraction x. It plays the role of
  pi r0^2 [a (1 - eps)^2 - b] in the Chou-Hannaford / Tondu-Lopez law (001 Eq. 3, 002 Eq. 2)
  but with the exponent n free, so one smooth curve meets both 004 figures: 284.3 N/V at
  x = 0 and 17.4 N/V at 95 mm (k_v = 0.1 MPa/V turns N/Pa into N/V: 1e5 g).
- p_th is the pressure the bladder needs to touch the braid before any pull appears
  (001 section 5: about 0.01 MPa; 003: about 0.045 MPa).
- k_bl is the bladder's own elasticity resisting contraction; k_s the braid lock-up when the
  muscle is stretched below its nominal length, which makes heavy loads barely move the
  muscle at first (004 isotonic threshold).
- F_f is braid friction (``pam_bench.models.friction.MaxwellSlip``) driven by the slip
  coordinate s = x + c_t F_bb^+: the fibres slide over the bladder when the length changes and
  when the braid tension changes (the bladder swelling under pressure stretches the braid by
  c_t per newton), so hysteresis shows in all three families (004). The break force of each
  element is f0_i + mu_i F_bb^+ (Coulomb: the braid presses on the bladder with its tension).
  Two bounds keep the friction a reaction that can at most hold the force, never reverse it:
  c_t sum(k_i) < 1 (while the elements stick, dF/dF_bb = 1 - c_t sum k_sticking > 0 at held
  x) and sum(mu_i) < 1 (while they slide, dF/dF_bb = 1 -+ sum mu_i > 0); both are checked.

Chamber volume from the inextensible-braid kinematics (001 Eq. 1-2): with thread length
b = l_n / cos(theta_0) and n_t = b sin(theta_0) / (pi d_n) turns,
l = b cos(theta), d = b sin(theta) / (pi n_t), V = pi d^2 l / 4 = b^3 sin^2(theta) cos(theta)
/ (4 pi n_t^2).
"""

from __future__ import annotations

import dataclasses
import math

from pam_bench.models.errors import ModelError
from pam_bench.models.friction import FrictionTrial, MaxwellSlip
from pam_bench.models.params import field

__all__ = ['MuscleParams', 'MuscleModel', 'MuscleOutput', 'MuscleTrial']

MuscleTrial = tuple[float, float, float, FrictionTrial | None]
"""(force N, stiffness -dF/dx N/m, friction N, friction trial or None without hysteresis)."""


@dataclasses.dataclass
class MuscleParams:
    """Parameters of ``MuscleModel`` (defaults calibrated to 004, see ``calibration``), and
    which muscle the bench holds (``kind``: ``pam_bench.models.bench_muscle``)."""

    kind: str = field('mckibben', '-', 'muscle law on the bench: mckibben (these parameters) '
                      'or straight_fibre (the straight_fibre.* parameters)')
    nominal_length_m: float = field(0.350, 'm', 'nominal length l_n (004)', 0.01, 10.0)
    nominal_diameter_m: float = field(0.020, 'm', 'nominal diameter d_n (004)', 0.001, 1.0)
    braid_angle_deg: float = field(20.0, 'deg', 'braid angle theta_0 at nominal length',
                                   1.0, 54.0)
    gain_n_per_pa: float = field(2.843e-3, 'N/Pa', 'isometric gain g_0 at x = 0',
                                 0.0, 1.0)
    gain_zero_contraction_m: float = field(0.150, 'm', 'contraction x_z where g(x) reaches 0',
                                           0.001, 10.0)
    gain_exponent: float = field(2.65, '-', 'exponent n of the gain curve', 0.1, 20.0)
    threshold_pressure_pa: float = field(2.0e4, 'Pa', 'pressure p_th before any pull',
                                         0.0, 1.0e6)
    bladder_stiffness_n_per_m: float = field(100.0, 'N/m', 'bladder elasticity k_bl',
                                             0.0, 1.0e9)
    stretch_stiffness_n_per_m: float = field(5.0e5, 'N/m', 'braid lock-up stiffness k_s for '
                                             'x < 0', 0.0, 1.0e10)
    hysteresis: bool = field(True, '-', 'model braid friction (Maxwell-slip)')
    friction_stiffness_n_per_m: list = field([3.0e5, 2.0e5, 1.0e5], 'N/m',
                                             'stiffness k_i of each friction element',
                                             0.0, 1.0e10)
    friction_break_force_n: list = field([1.0, 2.0, 2.0], 'N',
                                         'break force f0_i at zero load', 0.0, 1.0e5)
    friction_break_force_ratio: list = field([0.004, 0.008, 0.012], '-',
                                             'growth mu_i of the break force per newton of '
                                             'backbone force', 0.0, 1.0)
    slip_compliance_m_per_n: float = field(8.0e-7, 'm/N', 'braid slip c_t per newton of '
                                           'backbone force', 0.0, 1.0e-3)


@dataclasses.dataclass
class MuscleOutput:
    """One evaluation of the muscle: force N, stiffness -dF/dx N/m, friction N, volume m^3."""

    force_n: float
    stiffness_n_per_m: float
    friction_n: float
    volume_m3: float


class MuscleModel:
    """Quasi-static McKibben muscle with rate-independent friction hysteresis."""

    def __init__(self, params: MuscleParams | None = None) -> None:
        self.p = params or MuscleParams()
        if len({len(self.p.friction_stiffness_n_per_m), len(self.p.friction_break_force_n),
                len(self.p.friction_break_force_ratio)}) != 1:
            raise ModelError('friction_stiffness_n_per_m, friction_break_force_n and '
                             'friction_break_force_ratio must have the same length')
        if self.p.slip_compliance_m_per_n * sum(self.p.friction_stiffness_n_per_m) >= 1.0:
            raise ModelError('slip_compliance_m_per_n * sum(friction_stiffness_n_per_m) must '
                             'be < 1: sticking friction would make the force fall as the '
                             'pressure rises')
        if sum(self.p.friction_break_force_ratio) >= 1.0:
            raise ModelError('sum(friction_break_force_ratio) must be < 1: sliding friction '
                             'would exceed the force it resists')
        self.friction = MaxwellSlip(self.p.friction_stiffness_n_per_m,
                                    self.p.friction_break_force_n,
                                    self.p.friction_break_force_ratio)
        th0 = math.radians(self.p.braid_angle_deg)
        self._thread_m = self.p.nominal_length_m / math.cos(th0)
        self._turns = self._thread_m * math.sin(th0) / (math.pi * self.p.nominal_diameter_m)

    def reset(self, contraction_m: float = 0.0, pressure_pa: float = 0.0) -> None:
        """Friction relaxed at the given state."""
        self.friction.reset(self.slip(contraction_m, pressure_pa))

    # --- static parts -------------------------------------------------------------------
    def gain(self, contraction_m: float) -> float:
        """g(x), N/Pa."""
        r = 1.0 - contraction_m / self.p.gain_zero_contraction_m
        return self.p.gain_n_per_pa * r ** self.p.gain_exponent if r > 0.0 else 0.0

    def gain_slope(self, contraction_m: float) -> float:
        """dg/dx, N/(Pa m)."""
        r = 1.0 - contraction_m / self.p.gain_zero_contraction_m
        if r <= 0.0:
            return 0.0
        return (-self.p.gain_n_per_pa * self.p.gain_exponent * r ** (self.p.gain_exponent - 1.0)
                / self.p.gain_zero_contraction_m)

    def backbone(self, pressure_pa: float, contraction_m: float) -> float:
        """Friction-free force F_bb(p, x), N (may be negative before the clamp)."""
        dp = max(pressure_pa - self.p.threshold_pressure_pa, 0.0)
        f = self.gain(contraction_m) * dp - self.p.bladder_stiffness_n_per_m * contraction_m
        if contraction_m < 0.0:
            f -= self.p.stretch_stiffness_n_per_m * contraction_m
        return f

    def backbone_stiffness(self, pressure_pa: float, contraction_m: float) -> float:
        """-dF_bb/dx, N/m."""
        dp = max(pressure_pa - self.p.threshold_pressure_pa, 0.0)
        k = -self.gain_slope(contraction_m) * dp + self.p.bladder_stiffness_n_per_m
        if contraction_m < 0.0:
            k += self.p.stretch_stiffness_n_per_m
        return k

    def slip(self, contraction_m: float, pressure_pa: float) -> float:
        """Slip coordinate s = x + c_t F_bb^+, m."""
        tension = max(self.backbone(pressure_pa, contraction_m), 0.0)
        return contraction_m + self.p.slip_compliance_m_per_n * tension

    def volume(self, contraction_m: float) -> float:
        """Chamber volume V(x) from braid kinematics, m^3 (clamped at the braid's limits)."""
        c = (self.p.nominal_length_m - contraction_m) / self._thread_m
        c = min(max(c, 1.0e-6), 1.0)
        s2 = 1.0 - c * c
        return self._thread_m ** 3 * s2 * c / (4.0 * math.pi * self._turns ** 2)

    # --- evaluation ---------------------------------------------------------------------
    def trial(self, pressure_pa: float, contraction_m: float) -> MuscleTrial:
        """Evaluate the muscle at (p, x) from the kept friction state, without keeping the move.

        Returns:
            (F N, stiffness -dF/dx N/m, friction N, friction trial for ``commit``); F >= 0.
        """
        p = self.p
        r = 1.0 - contraction_m / p.gain_zero_contraction_m
        dp = pressure_pa - p.threshold_pressure_pa
        if dp < 0.0:
            dp = 0.0
        if r > 0.0:
            rn = r ** (p.gain_exponent - 1.0)
            f_bb = p.gain_n_per_pa * rn * r * dp
            k_bb = p.gain_n_per_pa * p.gain_exponent * rn / p.gain_zero_contraction_m * dp
        else:
            f_bb = k_bb = 0.0
        f_bb -= p.bladder_stiffness_n_per_m * contraction_m
        k_bb += p.bladder_stiffness_n_per_m
        if contraction_m < 0.0:
            f_bb -= p.stretch_stiffness_n_per_m * contraction_m
            k_bb += p.stretch_stiffness_n_per_m
        fr = None
        ff = kf = 0.0
        if p.hysteresis:
            tension = f_bb if f_bb > 0.0 else 0.0
            ct = p.slip_compliance_m_per_n
            fr = self.friction.trial(contraction_m + ct * tension, tension)
            ff = fr[0]
            # -dF/dx through s: ds/dx = 1 - c_t K_bb while the braid is under tension
            kf = fr[1] * (1.0 - ct * k_bb if f_bb > 0.0 else 1.0)
        f = f_bb - ff
        if f <= 0.0:
            return 0.0, 0.0, ff, fr
        return f, k_bb + kf, ff, fr

    def commit(self, trial: MuscleTrial) -> None:
        """Keep the friction state of a ``trial``."""
        if trial[3] is not None:
            self.friction.commit(trial[3])

    def step(self, pressure_pa: float, contraction_m: float) -> MuscleOutput:
        """Move to (p, x), updating the friction state, and return the muscle output.

        Raises:
            ModelError: p or x is not finite.
        """
        if not (math.isfinite(pressure_pa) and math.isfinite(contraction_m)):
            raise ModelError(f'muscle input not finite: p={pressure_pa!r}, x={contraction_m!r}')
        t = self.trial(pressure_pa, contraction_m)
        self.commit(t)
        return MuscleOutput(t[0], t[1], t[2], self.volume(contraction_m))

    def static_force(self, pressure_pa: float, contraction_m: float) -> float:
        """max(0, F_bb): the friction-free force, N."""
        return max(self.backbone(pressure_pa, contraction_m), 0.0)
