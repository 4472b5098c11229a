"""Sliding-mode force control of a pneumatic muscle, as a pam_bench controller plug-in.

After J. H. Lilly and L. Yang, "Sliding mode tracking for pneumatic muscle actuators in
opposing pair configuration", IEEE Transactions on Control Systems Technology 13(4), 2005,
and the boundary layer of J.-J. E. Slotine and W. Li, Applied Nonlinear Control (1991),
chapter 7. Per muscle, with the force error e = F* - F (N):

    s = e + lambda int(e) dt                       (the sliding surface, N)
    u_ff = the static inverse model's voltage for F* at x (004 section 3), or F* / k_hat
    u_fb = K sat(s / phi)                          (V; sat clips to [-1, 1])

The boundary layer of width phi (N) keeps the switching term continuous, so the valve command
does not chatter; the integral on the surface removes the steady error the feed-forward
leaves. The servo clamps u_ff + u_fb to the valve's range.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from pam_bench.vocabulary.params import field

__all__ = ['SlidingModeParams', 'SlidingModeForce']


@dataclasses.dataclass
class SlidingModeParams:
    """The controller's settings (module docstring)."""

    lambda_per_s: float = field(5.0, '1/s', 'weight lambda of the integral on the surface',
                                0.0, 1.0e3)
    gain_v: float = field(1.5, 'V', 'switching gain K', 0.0, 10.0)
    boundary_n: float = field(25.0, 'N', 'boundary layer width phi', 1e-3, 1.0e4)
    gain_estimate_n_per_v: float = field(250.0, 'N/V', 'k_hat: the feed-forward without an '
                                         'inverse model, F* / k_hat', 1.0, 1.0e5)


class SlidingModeForce:
    """One muscle channel's sliding-mode force controller (module docstring)."""

    settings = SlidingModeParams

    def __init__(self, settings: SlidingModeParams, servo: Any, inverse: Any) -> None:
        self.s = settings
        self.inverse = inverse
        self.integral = 0.0

    def reset(self) -> None:
        """Forget the integral."""
        self.integral = 0.0

    def step(self, dt_s: float, target: tuple[float, float, float], contraction_m: float,
             force_n: float) -> tuple[float, float]:
        """(feed-forward V, switching feedback V) for one control period."""
        f_star = target[0]
        e = f_star - force_n
        self.integral += e * dt_s
        surface = e + self.s.lambda_per_s * self.integral
        if self.inverse is not None:
            u_ff = self.inverse.static_voltage(f_star, contraction_m)
        else:
            u_ff = f_star / self.s.gain_estimate_n_per_v
        sat = max(-1.0, min(1.0, surface / self.s.boundary_n))
        return float(u_ff), self.s.gain_v * sat
