"""Holders of the muscle end without drive mechanics: the same sub-step interface as the drive.

``IdealHolder`` stands in for the drive when ``LoadingServoParams.dynamics`` is false:

    position mode:   x = x* + F / k_b                         (held at the set value)
    force, off:      x = x_0 + C (F - F*),  F* = 0 when off    (a soft force source)

with C = ``IDEAL_FORCE_COMPLIANCE_M_PER_N``, so the force settles on F* within a few sub-steps;
x is clamped to the belt travel. ``IdealHold`` keeps the muscle end at x = x_0 + F / k_b: an
angle held ideally (004 section 3.2 holds the pulley of the torque servo with the electric
drive). Units: m, N, m/N.
"""

from __future__ import annotations

import math
from typing import Protocol

from pam_bench.models.loading_servo.params import LoadingServoParams, LoadMode

__all__ = ['IdealHolder', 'IdealHold', 'IDEAL_FORCE_COMPLIANCE_M_PER_N']

IDEAL_FORCE_COMPLIANCE_M_PER_N = 1.0e-3


class HeldDrive(Protocol):
    """What an ideal holder reads and sets of its drive (``drive.LoadingServoModel``)."""

    p: LoadingServoParams
    mode: LoadMode
    setpoint: float
    contraction_m: float
    phi: float
    w: float
    r: float
    torque: float
    tau_max: float
    saturated: bool


class IdealHolder:
    """The ideal holder of a drive with ``dynamics: false`` (module docstring)."""

    def __init__(self, drive: HeldDrive) -> None:
        self.drive = drive

    def contraction(self, force_n: float) -> float:
        """Where the muscle end is held under ``force_n``, m."""
        drive, p = self.drive, self.drive.p
        if drive.mode == LoadMode.POSITION:
            x = drive.setpoint + force_n / p.belt_stiffness_n_per_m
        else:
            target = drive.setpoint if drive.mode == LoadMode.FORCE else 0.0
            x = drive.contraction_m + IDEAL_FORCE_COMPLIANCE_M_PER_N * (force_n - target)
        return min(max(x, p.travel_min_m), p.travel_max_m)

    def compliance(self, force_n: float) -> float:
        """dX/dF, m/N."""
        p = self.drive.p
        return (1.0 / p.belt_stiffness_n_per_m if self.drive.mode == LoadMode.POSITION
                else IDEAL_FORCE_COMPLIANCE_M_PER_N)

    def contraction_and_compliance(self, force_n: float) -> tuple[float, float]:
        """(X(F) m, dX/dF m/N)."""
        return self.contraction(force_n), self.compliance(force_n)

    def commit(self, force_n: float) -> float:
        """Keep the sub-step: the drive's angle, rate and torque follow the held end; returns
        the contraction, m."""
        drive, p = self.drive, self.drive.p
        x = self.contraction(force_n)
        drive.phi = (x - force_n / p.belt_stiffness_n_per_m) / drive.r
        drive.w = 0.0
        drive.torque = drive.r * force_n
        drive.saturated = abs(drive.torque) > drive.tau_max
        if drive.saturated:
            drive.torque = math.copysign(drive.tau_max, drive.torque)
        return x


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

    def compliance(self, force_n: float) -> float:
        """1 / k_b, m/N."""
        return 1.0 / self.k_b

    def contraction_and_compliance(self, force_n: float) -> tuple[float, float]:
        """(X(F) m, dX/dF m/N)."""
        return self.x0 + force_n / self.k_b, 1.0 / self.k_b

    def commit(self, force_n: float) -> None:
        """Nothing to keep."""
