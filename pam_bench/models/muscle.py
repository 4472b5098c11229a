"""McKibben muscle of the 004 bench: d_n = 20 mm, l_n = 350 mm, bladder free inside the braid.

Contraction x = l_n - l in m (x < 0 is stretch), gauge pressure p in Pa, force F in N.

Static force (quasi-static: the muscle's own mass and the gas inertia are neglected):

    F = max(0, F_bb(p, x) - F_f)                                             (never pushes)
    F_bb = g(x) e(p) - k_bl x + k_s (-x)^+ - k_l (x - x_l)^+
    g(x) = g_m + (g_0 - g_m) (1 - x / x_m)^n     for x <= x_m
    g(x) = g_m + g_r (x - x_m)                   for x > x_m
    e(p) = w [S((p - p_th) / w) - S(-p_th / w)],  S(z) = ln(1 + e^z)   (w > 0; (p - p_th)^+
                                                                        for w = 0)

- g(x) (N/Pa) is the isometric gain dF/dp at contraction x. It plays the role of
  pi r0^2 [a (1 - eps)^2 - b] in the Chou-Hannaford / Tondu-Lopez law (001 Eq. 3, 002 Eq. 2),
  shaped to 004's isometric figures (section 2.3): 284.3 N/V at x = 0 and a minimum of
  17.4 N/V at 95 mm over 0..110 mm (k_v = 0.1 MPa/V turns N/Pa into N/V: 1e5 g). A gain that
  only falls (the ideal braid's, and this law with g_m = g_r = 0) cannot have a minimum inside
  the range: it keeps falling to 110 mm (BENCHMARKS.md, 'Calibration against 004'). Past x_m
  the gain
  rises gently and linearly (g_r; n > 1 makes the falling branch flat at x_m, so the gain is
  continuous and has its minimum there); the muscle stays stable as long as its stiffness
  -dF/dx = k_bl - g_r e stays positive there, which ``MuscleModel`` checks at the valve's
  largest pressure (1 MPa).
- e(p) is the effective pressure: the bladder has to inflate against its own elasticity and
  close the gap to the braid before the braid takes the load (001 section 5: about 0.01 MPa;
  003: about 0.045 MPa). The contact grows over a band of width w around p_th rather than at
  once: the force starts gently at the lowest pressures (004's isotonic minimum of 0.13 mm/V at
  0 V and 100 N: the first 0.1 V barely moves a loaded muscle) and the lift-off of a light load
  is spread over w (004's isotonic maximum, 97.16 mm/V at 0.86 V and 50 N). e(0) = 0,
  de/dp = 1 / (1 + exp(-(p - p_th) / w)), e -> p - p_th - w ln(1 + exp(-p_th / w)) at high p.
- k_bl is the bladder's own elasticity resisting contraction; k_s the braid lock-up when the
  muscle is stretched below its nominal length, which makes heavy loads barely move the
  muscle at first (004 isotonic threshold); k_l the braid locking at its largest contraction
  x_l = l_n - b cos(54.74 deg) (the angle where 001 Eq. 3's force vanishes; b the thread
  length below), past which the muscle cannot shorten.
- F_f is braid friction (``pam_bench.models.friction.MaxwellSlip``) driven by the slip
  coordinate s = x + c_t F_bb^+: the fibres slide over the bladder when the length changes and
  when the braid tension changes (the bladder swelling under pressure stretches the braid by
  c_t per newton), so hysteresis shows in all three families (004). The break force of each
  element is f0_i + mu_i F_bb^+ (Coulomb: the braid presses on the bladder with its tension).
  Two bounds keep the friction a reaction that can at most hold the force, never reverse it:
  c_t sum(k_i) < 1 (while the elements stick, dF/dF_bb = 1 - c_t sum k_sticking > 0 at held
  x) and sum(mu_i) < 1 (while they slide, dF/dF_bb = 1 -+ sum mu_i > 0); both are checked.

The default parameters are fitted to 004's figures by ``pam-bench calibrate --target 004``
(``pam_bench.fit.calibrate``); ``pam-bench calibration`` reports each figure.

Chamber volume from the inextensible-braid kinematics (001 Eq. 1-2): with thread length
b = l_n / cos(theta_0) and n_t = b sin(theta_0) / (pi d_n) turns,
l = b cos(theta), d = b sin(theta) / (pi n_t), V = pi d^2 l / 4 = b^3 sin^2(theta) cos(theta)
/ (4 pi n_t^2).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, NamedTuple

import numpy as np

from pam_bench.models import jit
from pam_bench.models.errors import ModelError
from pam_bench.models.friction import FrictionTrial, MaxwellSlip, friction_on_backbone
from pam_bench.vocabulary.params import field

__all__ = ['FrictionMuscle', 'MuscleParams', 'MuscleModel', 'MuscleOutput', 'MuscleTrial',
           'LOCK_COS', 'gain_rise_limit', 'McKibbenRecord', 'softplus', 'effective_pressure',
           'backbone', 'braid_volume']

MAX_PRESSURE_PA = 1.0e6
"""The valve's largest output pressure (004: 0..1 MPa over 0..10 V), Pa."""
LOCK_COS = 1.0 / math.sqrt(3.0)
"""cos of the braid's lock angle, 54.74 deg, where 3 cos^2 theta = 1 (001 Eq. 3)."""


def gain_rise_limit(bladder_stiffness_n_per_m: float) -> float:
    """The gain's rise past x_m the muscle's stability allows, N/(Pa m), exclusive: g_r must
    stay below k_bl / 1 MPa, else past the gain minimum the muscle would pull harder as it
    shortens (``MuscleModel`` refuses it)."""
    return bladder_stiffness_n_per_m / MAX_PRESSURE_PA


MuscleTrial = tuple[float, float, float, FrictionTrial | None]
"""(force N, stiffness -dF/dx N/m, friction N, friction trial or None without hysteresis)."""


# --- the law, compiled (models.jit) -------------------------------------------------------
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


@jit.helper
def softplus(z: float) -> float:
    """log(1 + e^z), overflow-free (the contact band's smooth threshold, ``models.muscle``)."""
    return (z if z > 0.0 else 0.0) + math.log1p(math.exp(-abs(z)))


@jit.helper
def effective_pressure(p: float, mp: McKibbenRecord) -> float:
    """e(p) Pa of the module docstring for the gauge pressure p Pa (negative taken as 0)."""
    w, pth = mp.w, mp.pth
    p = p if p > 0.0 else 0.0
    if w <= 0.0:
        return p - pth if p > pth else 0.0
    z = (p - pth) / w
    e = w * softplus(z) - mp.e0
    return e if e > 0.0 else 0.0


@jit.helper
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


@dataclasses.dataclass
class MuscleParams:
    """Parameters of ``MuscleModel`` (defaults calibrated to 004, see ``calibration``), and
    which muscle the bench holds (``kind``: ``pam_bench.models.bench_muscle``).

    The friction's break forces, their growth with load and the slip compliance are not
    fitted to 004's figures (``fit.calibrate.FREE``); they are set so that the braid
    friction biases the extraction's midline gains by under 2 % against the friction-free
    backbone (the isometric gain at 80 mm is the most exposed) while the fit reaches 004's
    isotonic minimum (0.13 mm/V at 0 V, 100 N), which asks for a soft braid (BENCHMARKS.md,
    'Calibration against 004'; docs/long_runs.md, 'The statics re-fitted').
    """

    kind: str = field('mckibben', '-', 'muscle law on the bench: mckibben (these parameters), '
                      'straight_fibre (the straight_fibre.* parameters) or law (the force law '
                      'named by law, its parameters laws.LAW.*, these friction and geometry)',
                      choices=('mckibben', 'straight_fibre', 'law'))
    law: str = field('bench_mckibben', '-', 'with kind law: the force law of the zoo, or of a '
                     'plug-in, the bench holds (pam-bench plugins lists them)')
    law_core: str = field('auto', '-', 'with kind law: how the law runs: compiled (numba), '
                          'interpreted (as written), or auto: a scene decides before its run '
                          '(models.law_muscle.law_core_for), compiled elsewhere',
                          choices=('auto', 'compiled', 'interpreted'))
    nominal_length_m: float = field(0.350, 'm', 'nominal length l_n (004)', 0.01, 10.0)
    nominal_diameter_m: float = field(0.020, 'm', 'nominal diameter d_n (004)', 0.001, 1.0)
    braid_angle_deg: float = field(20.0, 'deg', 'braid angle theta_0 at nominal length',
                                   1.0, 54.0)
    gain_n_per_pa: float = field(3.161e-3, 'N/Pa', 'isometric gain g_0 at x = 0',
                                 0.0, 1.0)
    gain_min_n_per_pa: float = field(1.808e-4, 'N/Pa', 'smallest isometric gain g_m', 0.0, 1.0)
    gain_min_contraction_m: float = field(0.095, 'm', 'contraction x_m of the smallest gain',
                                          0.001, 10.0)
    gain_exponent: float = field(1.389, '-', 'exponent n of the gain curve', 1.0, 20.0)
    gain_rise_n_per_pa_m: float = field(3.244e-4, 'N/(Pa m)', 'rise g_r of the gain past x_m',
                                        0.0, 1.0)
    threshold_pressure_pa: float = field(8.415e4, 'Pa', 'pressure p_th of the bladder-braid '
                                         'contact', 0.0, 1.0e6)
    threshold_width_pa: float = field(3.898e4, 'Pa', 'width w of the contact band (0: sharp)',
                                      0.0, 1.0e6)
    bladder_stiffness_n_per_m: float = field(375.8, 'N/m', 'bladder elasticity k_bl',
                                             0.0, 1.0e9)
    stretch_stiffness_n_per_m: float = field(1.082e5, 'N/m', 'braid lock-up stiffness k_s for '
                                             'x < 0', 0.0, 1.0e10)
    lock_stiffness_n_per_m: float = field(5.0e5, 'N/m', 'braid lock stiffness k_l past the '
                                          'largest contraction x_l', 0.0, 1.0e10)
    hysteresis: bool = field(True, '-', 'model braid friction (Maxwell-slip)')
    friction_stiffness_n_per_m: list = field([6.909e4, 4.608e4, 2.303e4], 'N/m',
                                             'stiffness k_i of each friction element',
                                             0.0, 1.0e10)
    friction_break_force_n: list = field([0.6, 1.2, 1.2], 'N',
                                         'break force f0_i at zero load', 0.0, 1.0e5)
    friction_break_force_ratio: list = field([0.001, 0.002, 0.003], '-',
                                             'growth mu_i of the break force per newton of '
                                             'backbone force', 0.0, 1.0)
    slip_compliance_m_per_n: float = field(1.6e-6, 'm/N', 'braid slip c_t per newton of '
                                           'backbone force', 0.0, 1.0e-3)


@dataclasses.dataclass
class MuscleOutput:
    """One evaluation of the muscle: force N, stiffness -dF/dx N/m, friction N, volume m^3."""

    force_n: float
    stiffness_n_per_m: float
    friction_n: float
    volume_m3: float


class FrictionMuscle:
    """What every bench muscle shares: its friction-free backbone (``backbone_and_stiffness``,
    ``backbone``, ``volume``: per law) plus Maxwell-slip friction on s = x + c_t F_bb^+, never
    pushing (module docstring)."""

    p: Any
    friction: MaxwellSlip

    def backbone_and_stiffness(self, pressure_pa: float, contraction_m: float
                               ) -> tuple[float, float]:
        """(F_bb N, -dF_bb/dx N/m) of the law."""
        raise NotImplementedError

    def backbone(self, pressure_pa: float, contraction_m: float) -> float:
        """Friction-free force F_bb(p, x), N."""
        return self.backbone_and_stiffness(pressure_pa, contraction_m)[0]

    def volume(self, contraction_m: float) -> float:
        """Chamber volume, m^3."""
        raise NotImplementedError

    # --- evaluation ---------------------------------------------------------------------
    def trial(self, pressure_pa: float, contraction_m: float) -> MuscleTrial:
        """Evaluate the muscle at (p, x) from the kept friction state, without keeping the move.

        Returns:
            (F N, stiffness -dF/dx N/m, friction N, friction trial for ``commit``); F >= 0.
        """
        p = self.p
        f_bb, k_bb = self.backbone_and_stiffness(pressure_pa, contraction_m)
        if not p.hysteresis:
            f, k, ff, _ = friction_on_backbone(f_bb, k_bb, contraction_m, 0.0, 0.0, (),
                                                        (), (), (), [], [])
            return f, k, ff, None
        fr = self.friction
        zt = list(fr.z)
        st = [1] * len(zt)
        # -dF/dx through s: ds/dx = 1 - c_t K_bb while the braid is under tension
        f, k, ff, k_stick = friction_on_backbone(
            f_bb, k_bb, contraction_m, 1.0, p.slip_compliance_m_per_n, fr.k, fr.f0, fr.mu,
            fr.z, zt, st)
        return f, k, ff, (ff, k_stick, tuple(zt), tuple(v == 1 for v in st))

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


@jit.helper
def braid_volume(x: float, length_m: float, thread_m: float, turns: float) -> float:
    """Chamber volume V(x) = b^3 sin^2(theta) cos(theta) / (4 pi N^2) from the braid's
    kinematics, m^3, with cos(theta) = (l0 - x) / b clamped to [1e-6, 1] (the braid's limits):
    contraction x m, length l0 m, thread length b m, turns N."""
    c = (length_m - x) / thread_m
    c = min(max(c, 1.0e-6), 1.0)
    s2 = 1.0 - c * c
    return thread_m ** 3 * s2 * c / (4.0 * math.pi * turns ** 2)


class MuscleModel(FrictionMuscle):
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
        if self.p.gain_rise_n_per_pa_m >= gain_rise_limit(self.p.bladder_stiffness_n_per_m):
            raise ModelError('gain_rise_n_per_pa_m * 1 MPa must be < bladder_stiffness_n_per_m: '
                             'past the gain minimum the muscle would pull harder as it shortens')
        self.friction = MaxwellSlip(self.p.friction_stiffness_n_per_m,
                                    self.p.friction_break_force_n,
                                    self.p.friction_break_force_ratio)
        th0 = math.radians(self.p.braid_angle_deg)
        self._thread_m = self.p.nominal_length_m / math.cos(th0)
        self._turns = self._thread_m * math.sin(th0) / (math.pi * self.p.nominal_diameter_m)
        self.lock_contraction_m = self.p.nominal_length_m - self._thread_m * LOCK_COS
        w, pth = self.p.threshold_width_pa, self.p.threshold_pressure_pa
        self._e0 = w * softplus(-pth / w) if w > 0.0 else 0.0
        self._e_memo = (math.nan, 0.0)   # (p Pa, e(p) Pa): a sub-step tries one pressure
        self.record = self._record()

    def reset(self, contraction_m: float = 0.0, pressure_pa: float = 0.0) -> None:
        """Friction relaxed at the given state."""
        self.friction.reset(self.slip(contraction_m, pressure_pa))

    def _record(self) -> McKibbenRecord:
        """The parameters by name as the kernels take them (``McKibbenRecord``)."""
        p = self.p
        return McKibbenRecord(
            g0=p.gain_n_per_pa, gm=p.gain_min_n_per_pa, xm=p.gain_min_contraction_m,
            n=p.gain_exponent, gr=p.gain_rise_n_per_pa_m, pth=p.threshold_pressure_pa,
            w=p.threshold_width_pa, e0=self._e0, kbl=p.bladder_stiffness_n_per_m,
            ks=p.stretch_stiffness_n_per_m, kl=p.lock_stiffness_n_per_m,
            xl=self.lock_contraction_m, hysteresis=1.0 if p.hysteresis else 0.0,
            ct=p.slip_compliance_m_per_n)

    def arrays(self) -> tuple[Any, ...]:
        """The muscle as the compiled core takes it (``models.jit``): its parameters by
        name (``McKibbenRecord``), then the friction elements' stiffness, break force, growth,
        positions and sticking flags, shapes (n,)."""
        fr = self.friction
        return (self.record, np.array(fr.k), np.array(fr.f0), np.array(fr.mu), np.array(fr.z),
                np.array(fr.sticking, dtype=np.uint8))

    # --- static parts -------------------------------------------------------------------
    def effective_pressure(self, pressure_pa: float) -> tuple[float, float]:
        """(e(p) Pa, de/dp) of the bladder-braid contact (module docstring)."""
        w, pth = self.p.threshold_width_pa, self.p.threshold_pressure_pa
        p = pressure_pa if pressure_pa > 0.0 else 0.0
        if w <= 0.0:
            return (p - pth, 1.0) if p > pth else (0.0, 0.0)
        z = (p - pth) / w
        e = w * softplus(z) - self._e0
        return (e if e > 0.0 else 0.0), 1.0 / (1.0 + math.exp(-z)) if z > -700.0 else 0.0

    def gain(self, contraction_m: float) -> float:
        """g(x), N/Pa."""
        return self.gain_and_slope(contraction_m)[0]

    def gain_and_slope(self, contraction_m: float) -> tuple[float, float]:
        """(g(x) N/Pa, dg/dx N/(Pa m))."""
        p = self.p
        xm, gm = p.gain_min_contraction_m, p.gain_min_n_per_pa
        if contraction_m <= xm:
            r = 1.0 - contraction_m / xm
            rn = r ** (p.gain_exponent - 1.0)
            return (gm + (p.gain_n_per_pa - gm) * rn * r,
                    -(p.gain_n_per_pa - gm) * p.gain_exponent * rn / xm)
        return gm + p.gain_rise_n_per_pa_m * (contraction_m - xm), p.gain_rise_n_per_pa_m

    def backbone_and_stiffness(self, pressure_pa: float, contraction_m: float
                               ) -> tuple[float, float]:
        """(F_bb(p, x) N, -dF_bb/dx N/m): friction-free, before the clamp (may be negative);
        the compiled core's own function (``backbone``), here interpreted."""
        if self._e_memo[0] == pressure_pa:
            e = self._e_memo[1]
        else:
            e = self.effective_pressure(pressure_pa)[0]
            self._e_memo = (pressure_pa, e)
        return backbone(e, contraction_m, self.record)

    def backbone_stiffness(self, pressure_pa: float, contraction_m: float) -> float:
        """-dF_bb/dx, N/m."""
        return self.backbone_and_stiffness(pressure_pa, contraction_m)[1]

    def slip(self, contraction_m: float, pressure_pa: float) -> float:
        """Slip coordinate s = x + c_t F_bb^+, m."""
        tension = max(self.backbone(pressure_pa, contraction_m), 0.0)
        return contraction_m + self.p.slip_compliance_m_per_n * tension

    def volume(self, contraction_m: float) -> float:
        """Chamber volume V(x) from braid kinematics, m^3 (``braid_volume``)."""
        return braid_volume(contraction_m, self.p.nominal_length_m, self._thread_m, self._turns)
