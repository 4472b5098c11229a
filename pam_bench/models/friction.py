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
core's (``compiled.slip_elements``), run here interpreted on them.
"""

from __future__ import annotations

from typing import Any

from pam_bench.models import compiled

__all__ = ['MaxwellSlip', 'FrictionTrial']

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
        (the elements' law: ``compiled.slip_elements``)."""
        zt = list(self.z)
        st = [1] * len(zt)
        force, k_stick = compiled.slip_elements(s_m, load_n if load_n > 0.0 else 0.0, self.k,
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

