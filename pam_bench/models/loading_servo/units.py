"""The loading servo's drive in a drive's own units (CiA 402): per mille of rated torque, counts.

The bench's loading servo (004) is a motor with a gear of ratio i and a pulley of pitch radius r
that pulls on the muscle. A muscle tension F (N) is a motor torque T = F r / i, which a CiA 402
drive takes as per mille of its rated torque (object 0x6071); a contraction x (m) is a pulley
angle x / r, which it takes in counts of the output encoder, 2^bits per revolution (0x607A).
Both the driver on the bus (``buses.canopen_drive``) and the bench served behind it
(``twin.buses``) convert with the same ``DriveScale``.
"""

from __future__ import annotations

import dataclasses
import math

from pam_bench.models.loading_servo.params import LoadingServoParams
from pam_bench.vocabulary.params import field

__all__ = ['DriveScale']

_SERVO = LoadingServoParams()


@dataclasses.dataclass
class DriveScale:
    """The drive's units and the mechanics between the motor and the muscle (module
    docstring); the defaults are the bench's loading servo (``models.loading_servo``)."""

    pitch_diameter_m: float = field(_SERVO.pitch_diameter_m, 'm', 'pulley pitch diameter',
                                    0.001, 10.0)
    gear_ratio: float = field(_SERVO.gear_ratio, '-', 'gear ratio i (motor turns per pulley '
                              'turn)', 1.0, 1.0e4)
    rated_torque_nm: float = field(_SERVO.rated_torque_nm, 'N m', 'motor rated torque (0x6076: '
                                   'what 1000 per mille of target torque is)', 1e-3, 1.0e4)
    encoder_bits_per_rev: int = field(_SERVO.encoder_bits_per_rev, 'bit', 'counts per pulley '
                                      'revolution of the position (0x6064, 0x607A), as a power '
                                      'of two', 1, 31)

    @property
    def radius_m(self) -> float:
        """Pulley pitch radius r, m."""
        return self.pitch_diameter_m / 2.0

    def torque_permille(self, force_n: float) -> int:
        """Target torque (0x6071, per mille of rated, int16) for a muscle tension F (N)."""
        t = force_n * self.radius_m / self.gear_ratio
        return max(-32768, min(32767, round(1000.0 * t / self.rated_torque_nm)))

    def force_of_permille(self, permille: int) -> float:
        """The muscle tension (N) a motor torque in per mille of rated pulls with."""
        return permille * 1e-3 * self.rated_torque_nm * self.gear_ratio / self.radius_m

    def counts(self, angle_rad: float) -> int:
        """Pulley angle (rad) in position counts (int32)."""
        return round(angle_rad / (2.0 * math.pi) * 2**self.encoder_bits_per_rev)

    def angle_of(self, counts: int) -> float:
        """Position counts as a pulley angle (rad)."""
        return counts * 2.0 * math.pi / 2**self.encoder_bits_per_rev
