"""The 004 loading servo: parameters and modes, drive mechanics and its sub-step, holders, law."""

from __future__ import annotations

from pam_bench.models.loading_servo.drive import LoadingServoModel, ServoOutput, SubStep
from pam_bench.models.loading_servo.holders import IDEAL_FORCE_COMPLIANCE_M_PER_N, IdealHold
from pam_bench.models.loading_servo.law import DriveState, drive_from_law, law_of
from pam_bench.models.loading_servo.params import LAW_PARAMETERS, LoadingServoParams, LoadMode

__all__ = ['LoadMode', 'LoadingServoParams', 'LAW_PARAMETERS', 'LoadingServoModel',
           'ServoOutput', 'SubStep', 'IdealHold', 'IDEAL_FORCE_COMPLIANCE_M_PER_N',
           'DriveState', 'law_of', 'drive_from_law']
