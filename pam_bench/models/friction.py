"""Rate-independent braid friction: a Maxwell-slip (generalised Prandtl-Ishlinskii) model.

004 (section 2.2) attributes the hysteresis of all three static families to friction between
the braid fibres and between the braid and the bladder. The friction force is

    F_f = sum_i phi_i,   phi_i = k_i (s - z_i),   |phi_i| <= f_i(N) = f0_i + mu_i N

with element stiffness k_i (N/m), break force f_i (N) growing with the load N (N) that presses
the fibres together (Coulomb: the muscle passes the braid tension, its backbone force), and
slip coordinate s (m). Each element sticks (z_i fixed) until its spring force reaches f_i, then
slides with z_i = s -+ f_i / k_i.

The update is an exact algebraic projection onto |phi_i| <= f_i: it uses no velocity and no
sign(v), so it cannot chatter at a velocity reversal, and the result depends only on the path
of s, not on the step size (rate independence). ``trial`` evaluates a move without keeping it
(the implicit sub-step of ``pam_bench.models.coupling`` tries several); ``commit`` keeps one.
The element bank is short (three elements by default) and evaluated thousands of times per
simulated second, so the object keeps Python floats and tuples; the law itself is the compiled
core's (``slip_elements``), run here interpreted on them.
"""

from __future__ import annotations

from typing import Any

from pam_bench.models import jit
from pam_bench.models.jit import Slots, Values

__all__ = ['MaxwellSlip', 'FrictionTrial', 'slip_elements', 'friction_on_backbone']


# --- the law, compiled (models.jit) -------------------------------------------------------
@jit.helper
def slip_elements(s: float, load: float, fk: Values, ff0: Values, fmu: Values, z: Values,
                  zt: Slots, st: Slots) -> tuple[float, float]:
    """The Maxwell-slip elements (``models.friction``, 004 section 2.2) moved to the slip
    coordinate ``s`` m under ``load`` N >= 0 from their positions ``z`` m: element i
    (stiffness fk_i N/m, break force ff0_i + fmu_i load N) sticks while |s - z_i| < lim_i =
    (ff0_i + fmu_i load) / fk_i, else slides to s -+ lim_i. Its trial position goes to
    ``zt[i]``, 1 (sticking) or 0 to ``st[i]``. Returns (F_f = sum fk_i (s - zt_i) N, the
    sticking elements' stiffness N/m). Arrays or sequences of length n."""
    force = 0.0
    k_stick = 0.0
    for i in range(len(fk)):
        k = fk[i]
        lim = (ff0[i] + fmu[i] * load) / k
        zi = z[i]
        d = s - zi
        if d >= lim:
            zi = s - lim
            st[i] = 0
        elif d <= -lim:
            zi = s + lim
            st[i] = 0
        else:
            k_stick += k
            st[i] = 1
        zt[i] = zi
        force += k * (s - zi)
    return force, k_stick


@jit.helper
def friction_on_backbone(f_bb: float, k_bb: float, x: float, hysteresis: float, ct: float,
                         fk: Values, ff0: Values, fmu: Values, z: Values, zt: Slots,
                         st: Slots) -> tuple[float, float, float, float]:
    """A bench muscle at contraction ``x`` m from its backbone (F_bb N, K_bb = -dF_bb/dx N/m):
    with ``hysteresis`` (1) the braid friction F_f on s = x + c_t F_bb^+ under the load F_bb^+
    (``slip_elements``; trial state into ``zt``, ``st``), F = F_bb - F_f, never pushing, and
    -dF/dx = K_bb + K_stick (1 - c_t K_bb while the braid is under tension). Returns
    (F N, -dF/dx N/m, F_f N, K_stick N/m); F <= 0 gives (0, 0, F_f, K_stick)."""
    ff = 0.0
    kf = 0.0
    k_stick = 0.0
    if hysteresis != 0.0:
        tension = f_bb if f_bb > 0.0 else 0.0
        ff, k_stick = slip_elements(x + ct * tension, tension, fk, ff0, fmu, z, zt, st)
        kf = k_stick * (1.0 - ct * k_bb if f_bb > 0.0 else 1.0)
    f = f_bb - ff
    if f <= 0.0:
        return 0.0, 0.0, ff, k_stick
    return f, k_bb + kf, ff, k_stick


FrictionTrial = tuple[float, float, tuple[float, ...], tuple[bool, ...]]
"""(friction force N, stiffness dF_f/ds of the sticking elements N/m, z_i m, sticking_i)."""


class MaxwellSlip:
    """Maxwell-slip element bank.

    Args:
        stiffness_n_per_m: k_i, length n.
        break_force_n: f0_i, length n.
        break_force_ratio: mu_i, break force per newton of load, length n.
    """

    def __init__(self, stiffness_n_per_m: list[float], break_force_n: list[float],
                 break_force_ratio: list[float]) -> None:
        self.k = tuple(float(v) for v in stiffness_n_per_m)
        self.f0 = tuple(float(v) for v in break_force_n)
        self.mu = tuple(float(v) for v in break_force_ratio)
        if not (len(self.k) == len(self.f0) == len(self.mu)):
            raise ValueError('friction element lists must have equal lengths')
        if any(k <= 0.0 for k in self.k):
            raise ValueError('friction element stiffnesses must be > 0 N/m')
        self.z: tuple[float, ...] = (0.0,) * len(self.k)
        self.sticking: tuple[bool, ...] = (True,) * len(self.k)

    def reset(self, s_m: float = 0.0) -> None:
        """All elements relaxed (zero force) at slip coordinate ``s_m``."""
        self.z = (float(s_m),) * len(self.k)
        self.sticking = (True,) * len(self.k)

    def trial(self, s_m: float, load_n: float) -> FrictionTrial:
        """The move to slip coordinate ``s_m`` (m) under the load ``load_n`` (N), not kept
        (the elements' law: ``slip_elements``)."""
        zt = list(self.z)
        st = [1] * len(zt)
        force, k_stick = slip_elements(s_m, load_n if load_n > 0.0 else 0.0, self.k,
                                                self.f0, self.mu, self.z, zt, st)
        return force, k_stick, tuple(zt), tuple(v == 1 for v in st)

    def commit(self, trial: FrictionTrial) -> None:
        """Keep the element state of a ``trial``."""
        self.z, self.sticking = trial[2], trial[3]

    def set_state(self, z: Any, sticking: Any) -> None:
        """Take the element positions (m) and sticking flags a compiled solve left, shapes
        (n,)."""
        self.z = tuple(float(v) for v in z)
        self.sticking = tuple(bool(v) for v in sticking)

    def force(self, s_m: float, load_n: float) -> float:
        """Advance to slip coordinate ``s_m`` (m) under the load ``load_n`` (N); return F_f, N."""
        t = self.trial(s_m, load_n)
        self.commit(t)
        return t[0]

