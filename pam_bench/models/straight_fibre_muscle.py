"""The straight-fibre muscle of 000 as a bench muscle (``muscle.kind: straight_fibre``).

A silicone tube of bore Phi0 (m) and free length L_m0 (m) with axial fibres in its wall is
divided by rings into n segments of L0 = L_m0 / n (000 section 3.2, step 2; n = N + 1 with N
rings). Contraction x (m; x < 0 is stretch), contraction ratio eps = x / L_m0, gauge pressure
p (Pa), force F (N).

Static force (quasi-static): 000's correlation graph read backwards
(``pam_bench.models.laws.straight_fibre``, its docstring derives it):

    F_bb = c p L0^2 10^(-lambda(eps / k + r0))              for x >= 0
    F_bb = F_bb(p, 0) + k_s (-x)                            for x < 0 (the fibres lock)
    F = max(0, F_bb - F_f)

lambda = log10(P L0^2 / F) as a function of the segment's ratio dL / L0 on the graph's
column at Phi0 / L0 (bilinear interpolation of Table 4, the end segments continued).

Calibration to 000's prototype (Table 1: tube 250 mm long, 34 mm outside, 6 mm wall). The
graph as printed cannot give the prototype: its 6 mm wall is outside Table 6, and even the
uncorrected graph gives 37 % contraction at 10 N and 0.22 MPa where the prototype reached
18.1 %, and it has no point at zero contraction (its lowest ratio at Phi0 / L0 = 0.26 is 9 %),
where the prototype held 558 N. Three constants fix that: k (scale of the contraction), r0
(the segment ratio at the graph's origin of the muscle's stroke) and c (pressure
effectiveness), fitted by least squares to the eight figures of 000 section 2.3 (3 and 4
segments at 0.22 MPa: the contraction at 10 and 150 N, and at the 558 / 433 N and 127 / 35 N
forces) with one set for both versions: the segment count enters only through L0, as in 000.
Phi0 is read as the bore (22 mm): with the outside diameter the 4-segment Phi0 / L0 = 0.54 is
off the graph. The fit's residuals, and the campaign that checks them through the nodes, are
in BENCHMARKS.md ('The straight-fibre muscle'). k = 1 - K_S s, r0 = 0, c = 1 is the graph
as 000 prints it, for a muscle whose wall Table 6 covers.

Hysteresis: 000 (section 2.3) sees two branches that open with the deformation and blames
the rubber's viscoelasticity. The bench models its rate-independent part only, with the same
Maxwell-slip friction as the McKibben (``pam_bench.models.friction``) on the slip coordinate
s = x + c_t F_bb^+ and break forces f0_i + mu_i F_bb^+ (a loop that widens with the force and
so with the deformation it comes with); the creep 000 also mentions is not modelled.

Chamber volume: each segment's wall bulges between its rings while its fibres keep their
length L0 (inextensible, 000 section 2). With a parabolic profile of height h over the chord
c = L0 (1 - eps), the fibre length c (1 + 8 h^2 / (3 c^2)) = L0 gives
h = c sqrt(3 (L0 / c - 1) / 8), and the segment holds pi c (R^2 + 4 R h / 3 + 8 h^2 / 15)
with R = Phi0 / 2; V = n times that (m^3).
"""

from __future__ import annotations

import dataclasses
import math

from pam_bench.models.errors import ModelError
from pam_bench.models.friction import MaxwellSlip
from pam_bench.models.laws.straight_fibre import Correlation
from pam_bench.models.muscle import FrictionMuscle
from pam_bench.vocabulary.errors import ParameterError
from pam_bench.vocabulary.params import field

__all__ = ['StraightFibreParams', 'StraightFibreMuscle']

_LN10 = math.log(10.0)


@dataclasses.dataclass
class StraightFibreParams:
    """Parameters of ``StraightFibreMuscle`` (defaults: 000's 3-segment prototype)."""

    free_length_m: float = field(0.250, 'm', 'free length L_m0 (000 Table 1)', 0.01, 10.0)
    bore_m: float = field(0.022, 'm', 'resting bore Phi0 (000 Table 1: 34 mm tube, 6 mm wall)',
                          0.001, 1.0)
    segments: int = field(3, '-', 'segments N + 1 between the end caps and the N rings', 1, 100)
    contraction_scale: float = field(0.6785, '-', 'k: muscle ratio per graph ratio (000 '
                                     'prototype fit)', 0.05, 3.0)
    contraction_offset: float = field(0.1400, '-', 'r0: graph ratio at zero contraction (000 '
                                      'prototype fit)', -0.5, 0.5)
    pressure_scale: float = field(0.7069, '-', 'c: pressure effectiveness (000 prototype fit)',
                                  1.0e-3, 1.0e3)
    stretch_stiffness_n_per_m: float = field(5.0e5, 'N/m', 'fibre lock-up stiffness k_s for '
                                             'x < 0', 0.0, 1.0e10)
    hysteresis: bool = field(True, '-', 'model the rubber friction (Maxwell-slip)')
    friction_stiffness_n_per_m: list = field([2.0e5, 1.0e5, 5.0e4], 'N/m',
                                             'stiffness k_i of each friction element',
                                             0.0, 1.0e10)
    friction_break_force_n: list = field([0.3, 0.5, 0.5], 'N', 'break force f0_i at zero load',
                                         0.0, 1.0e5)
    friction_break_force_ratio: list = field([0.005, 0.01, 0.015], '-',
                                             'growth mu_i of the break force per newton of '
                                             'backbone force', 0.0, 1.0)
    slip_compliance_m_per_n: float = field(2.0e-6, 'm/N', 'slip c_t per newton of backbone '
                                           'force', 0.0, 1.0e-3)


class StraightFibreMuscle(FrictionMuscle):
    """Quasi-static straight-fibre muscle with rate-independent hysteresis; the interface of
    ``MuscleModel`` (trial / commit / step / volume / reset / static_force)."""

    def __init__(self, params: StraightFibreParams | None = None) -> None:
        """Build the graph's column and the friction bank.

        Raises:
            ModelError: inconsistent friction lists.
            ParameterError: Phi0 / L0 off the graph.
        """
        self.p = params or StraightFibreParams()
        p = self.p
        if len({len(p.friction_stiffness_n_per_m), len(p.friction_break_force_n),
                len(p.friction_break_force_ratio)}) != 1:
            raise ModelError('friction_stiffness_n_per_m, friction_break_force_n and '
                             'friction_break_force_ratio must have the same length')
        if p.slip_compliance_m_per_n * sum(p.friction_stiffness_n_per_m) >= 1.0:
            raise ModelError('slip_compliance_m_per_n * sum(friction_stiffness_n_per_m) must '
                             'be < 1')
        if sum(p.friction_break_force_ratio) >= 1.0:
            raise ModelError('sum(friction_break_force_ratio) must be < 1')
        self.segment_m = p.free_length_m / p.segments
        try:
            self.graph = Correlation(p.bore_m / self.segment_m)
        except ParameterError as e:
            raise ParameterError(f'straight_fibre: bore {p.bore_m * 1e3:g} mm over segment '
                             f'{self.segment_m * 1e3:g} mm: {e}') from e
        self.friction = MaxwellSlip(p.friction_stiffness_n_per_m, p.friction_break_force_n,
                                    p.friction_break_force_ratio)
        self._scale = p.pressure_scale * self.segment_m ** 2      # c L0^2, m^2

    def reset(self, contraction_m: float = 0.0, pressure_pa: float = 0.0) -> None:
        """Friction relaxed at the given state."""
        self.friction.reset(self.slip(contraction_m, pressure_pa))

    # --- static parts -------------------------------------------------------------------
    def backbone_and_stiffness(self, pressure_pa: float, contraction_m: float
                               ) -> tuple[float, float]:
        """(F_bb N, -dF_bb/dx N/m), friction-free."""
        p = self.p
        if pressure_pa <= 0.0:
            f = k = 0.0
        else:
            eps = contraction_m / p.free_length_m if contraction_m > 0.0 else 0.0
            lam, slope = self.graph.log_pi3(eps / p.contraction_scale + p.contraction_offset)
            f = self._scale * pressure_pa * 10.0 ** -lam if lam < 300.0 else 0.0
            k = (f * _LN10 * slope / (p.contraction_scale * p.free_length_m)
                 if contraction_m >= 0.0 else 0.0)
        if contraction_m < 0.0:
            f -= p.stretch_stiffness_n_per_m * contraction_m
            k += p.stretch_stiffness_n_per_m
        return f, k

    def slip(self, contraction_m: float, pressure_pa: float) -> float:
        """Slip coordinate s = x + c_t F_bb^+, m."""
        return contraction_m + self.p.slip_compliance_m_per_n * max(
            self.backbone(pressure_pa, contraction_m), 0.0)

    def volume(self, contraction_m: float) -> float:
        """Chamber volume V(x) of the bulging segments (module docstring), m^3."""
        seg = self.segment_m
        chord = seg * (1.0 - min(max(contraction_m / self.p.free_length_m, 0.0), 0.9))
        h = chord * math.sqrt(3.0 * (seg / chord - 1.0) / 8.0)
        r = 0.5 * self.p.bore_m
        return self.p.segments * math.pi * chord * (r * r + 4.0 * r * h / 3.0 + 8.0 * h * h / 15.0)
