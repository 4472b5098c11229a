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
of s, not on the step size (rate independence).
"""

from __future__ import annotations

import numpy as np

__all__ = ['MaxwellSlip']


class MaxwellSlip:
    """Maxwell-slip element bank.

    Args:
        stiffness_n_per_m: k_i, shape (n,).
        break_force_n: f0_i, shape (n,).
        break_force_ratio: mu_i, break force per newton of load, shape (n,).
    """

    def __init__(self, stiffness_n_per_m: list[float], break_force_n: list[float],
                 break_force_ratio: list[float]) -> None:
        self.k = np.asarray(stiffness_n_per_m, dtype=float)
        self.f0 = np.asarray(break_force_n, dtype=float)
        self.mu = np.asarray(break_force_ratio, dtype=float)
        if not (self.k.shape == self.f0.shape == self.mu.shape):
            raise ValueError('friction element lists must have equal lengths')
        self.z = np.zeros_like(self.k)
        self.sticking = np.ones(self.k.shape, dtype=bool)

    def reset(self, s_m: float = 0.0) -> None:
        """All elements relaxed (zero force) at slip coordinate ``s_m``."""
        self.z[:] = s_m
        self.sticking[:] = True

    def force(self, s_m: float, load_n: float) -> float:
        """Advance to slip coordinate ``s_m`` (m) under the load ``load_n`` (N); return F_f, N."""
        if self.k.size == 0:
            return 0.0
        limit = (self.f0 + self.mu * max(load_n, 0.0)) / self.k   # m of pre-slide
        d = s_m - self.z
        over = np.abs(d) >= limit
        self.z = np.where(over, s_m - np.sign(d) * limit, self.z)
        self.sticking = ~over
        return float(np.dot(self.k, s_m - self.z))

    @property
    def sticking_stiffness(self) -> float:
        """dF_f/ds of the elements currently sticking, N/m."""
        return float(self.k[self.sticking].sum())
