"""Parameters and modes of the 004 loading servo (figures: 004 section 2.1; the mechanics and
the controller they parametrise: ``models.loading_servo.drive``)."""

from __future__ import annotations

import dataclasses
import enum

from pam_bench.models.constants import PULLEY_PITCH_DIAMETER_M
from pam_bench.vocabulary.params import field

__all__ = ['LoadMode', 'LoadingServoParams', 'LAW_PARAMETERS']


class LoadMode(enum.IntEnum):
    """Modes of the loading servo (values match LoadCommand.MODE_*)."""

    OFF = 0
    FORCE = 1
    POSITION = 2


@dataclasses.dataclass
class LoadingServoParams:
    """Parameters of ``LoadingServoModel``."""

    pitch_diameter_m: float = field(PULLEY_PITCH_DIAMETER_M, 'm', 'pulley pitch diameter (004)',
                                    0.001, 10.0)
    rated_torque_nm: float = field(1.27, 'N m', 'motor rated torque (004)', 0.0, 1.0e4)
    gear_ratio: float = field(70.0, '-', 'planetary gear ratio i (004)', 1.0, 1.0e4)
    force_limit_n: float = field(2792.0, 'N', 'largest force on the muscle (004)', 0.0, 1.0e6)
    backlash_arcmin: float = field(9.0, 'arcmin', 'gear backlash b_l (004: at most 9)',
                                   0.0, 600.0)
    backlash_force_n: float = field(5.0, 'N', 'force F_bl over which the play is taken up',
                                    1.0e-3, 1.0e4)
    inertia_kg_m2: float = field(0.15, 'kg m^2', 'inertia J reflected to the gear output',
                                 1.0e-6, 1.0e3)
    damping_nm_s_per_rad: float = field(0.5, 'N m s/rad', 'viscous damping c at the output',
                                        0.0, 1.0e4)
    belt_stiffness_n_per_m: float = field(2.0e6, 'N/m', 'belt and load-cell stiffness k_b',
                                          1.0e2, 1.0e12)
    travel_min_m: float = field(-0.05, 'm', 'end stop of the belt travel (stretch side)',
                                -10.0, 0.0)
    travel_max_m: float = field(0.16, 'm', 'end stop of the belt travel (contraction side)',
                                0.0, 10.0)
    speed_limit_rad_s: float = field(4.49, 'rad/s', 'output speed limit w_max (3000 rpm / i)',
                                     1.0e-3, 1.0e4)
    dynamics: bool = field(True, '-', 'simulate the drive mechanics; false: ideal holder')
    force_kp: float = field(5.0, '-', 'force loop proportional gain K_p', 0.0, 1.0e4)
    force_ki_per_s: float = field(12.0, '1/s', 'force loop integral gain K_i', 0.0, 1.0e6)
    force_kd_s: float = field(1.8, 's', 'force loop derivative gain K_d', 0.0, 1.0e4)
    force_integral_band_n: float = field(25.0, 'N', 'force loop integrates only while the '
                                         'force is within this of the set value', 0.0, 1.0e6)
    position_kp_n_per_m: float = field(2.0e6, 'N/m', 'position loop gain K_px', 0.0, 1.0e10)
    position_ki_n_per_m_s: float = field(1.0e7, 'N/(m s)', 'position loop integral K_ix',
                                         0.0, 1.0e12)
    position_kd_n_s_per_m: float = field(3.0e4, 'N s/m', 'position loop derivative K_dx',
                                         0.0, 1.0e9)
    encoder_bits_per_rev: int = field(16, 'bit', 'counts per revolution of the encoder the '
                                      'position loop reads (004: 16)', 1, 52)


# the parameters the sub-step law needs, in the order ``law`` and ``from_law`` use
LAW_PARAMETERS = tuple(f.name for f in dataclasses.fields(LoadingServoParams))
