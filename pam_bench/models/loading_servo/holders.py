"""Holders of the muscle end without drive mechanics: the same sub-step interface as the drive.

The ideal holder that stands in for the drive when ``LoadingServoParams.dynamics`` is false is
part of the drive's law (``drive.drive_ideal_contraction``, ``drive_commit``):

    position mode:   x = x* + F / k_b                         (held at the set value)
    force, off:      x = x_0 + C (F - F*),  F* = 0 when off    (a soft force source)

with C = ``IDEAL_FORCE_COMPLIANCE_M_PER_N``, so the force settles on F* within a few sub-steps;
x is clamped to the belt travel, and the drive's angle, rate and torque follow the held end.
``IdealHold`` keeps the muscle end at x = x_0 + F / k_b: an angle held ideally (004 section
3.2 holds the pulley of the torque servo with the electric drive). Units: m, N, m/N.
"""

from __future__ import annotations

from pam_bench.models.loading_servo.substep import IDEAL_FORCE_COMPLIANCE_M_PER_N

__all__ = ['IdealHold', 'IDEAL_FORCE_COMPLIANCE_M_PER_N']


class IdealHold:
    """Keeps the muscle end at x = x_0 + F / k_b (module docstring)."""

    def __init__(self, contraction_m: float, belt_stiffness_n_per_m: float) -> None:
        self.x0 = contraction_m
        self.k_b = belt_stiffness_n_per_m

    def prepare(self, d: float) -> None:
        """Nothing to prepare (no dynamics)."""

    def contraction(self, force_n: float) -> float:
        """x_0 + F / k_b, m."""
        return self.x0 + force_n / self.k_b

    def contraction_and_compliance(self, force_n: float) -> tuple[float, float]:
        """(X(F) m, dX/dF m/N)."""
        return self.x0 + force_n / self.k_b, 1.0 / self.k_b

    def commit(self, force_n: float) -> None:
        """Nothing to keep."""
