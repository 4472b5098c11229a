"""The torque servo's parameters: one settings class that the controller, its plug-ins, the
node, the twin and the scenes all read (004 section 3.2)."""

from __future__ import annotations

import dataclasses

from pam_bench.models.constants import PULLEY_PITCH_DIAMETER_M
from pam_bench.vocabulary.params import field

__all__ = ['TorqueServoParams']


@dataclasses.dataclass
class TorqueServoParams:
    """Parameters of ``TorqueServoController``."""

    pitch_diameter_m: float = field(PULLEY_PITCH_DIAMETER_M, 'm', 'pulley pitch diameter (004)',
                                    0.001, 10.0)
    rest_contraction_m: float = field(0.04, 'm', 'contraction x0 of both muscles at theta = 0',
                                      0.0, 0.15)
    max_torque_nm: float = field(25.46, 'N m', 'largest torque set point (004)', 0.0, 1e4)
    pretension_n: float = field(300.0, 'N', 'base force F_p of both muscles', 0.0, 5000.0)
    min_force_n: float = field(50.0, 'N', 'least force set point of a muscle F_min',
                               0.0, 5000.0)
    kp_v_per_n: float = field(0.004, 'V/N', 'PID proportional gain', 0.0, 10.0, tunable=True)
    ki_v_per_n_s: float = field(0.1, 'V/(N s)', 'PID integral gain', 0.0, 100.0, tunable=True)
    kd_v_s_per_n: float = field(1.0e-4, 'V s/N', 'PID derivative gain', 0.0, 10.0,
                                tunable=True)
    derivative_filter_s: float = field(0.01, 's', 'PID derivative filter T_f', 1e-5, 10.0,
                                       tunable=True)
    voltage_min_v: float = field(0.0, 'V', 'lowest valve voltage', 0.0, 10.0)
    voltage_max_v: float = field(6.0, 'V', 'highest valve voltage (0.6 MPa)', 0.0, 10.0)
