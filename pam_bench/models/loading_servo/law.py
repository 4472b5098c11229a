"""The drive's sub-step law as the DriveLaw message carries it (``sim/pulley/law``).

The loading-servo node publishes, at the end of every exchange, what a copy of its drive needs
to follow the next exchange's sub-steps: the parameters in ``LAW_PARAMETERS`` order and the
state in ``DriveState`` order. The muscle node rebuilds the drive from them (``drive_from_law``)
and solves its end with it (``models.coupling``); the drive then replays the same sub-steps
and reaches the same state to the last bit.
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

from pam_bench.models.errors import ModelError
from pam_bench.models.loading_servo.drive import LoadingServoModel
from pam_bench.models.loading_servo.params import LAW_PARAMETERS, LoadingServoParams, LoadMode

__all__ = ['DriveState', 'law_of', 'drive_from_law']


class DriveState(NamedTuple):
    """The drive's state between sub-steps (SI: rad, rad/s, N s or m s, N, rad, m)."""

    angle_rad: float          # gear output angle phi
    rate_rad_s: float         # its rate w
    integral: float           # controller integral I
    force_n: float            # muscle force of the last sub-step
    encoder_rad: float        # encoder reading of the last sub-step
    contraction_m: float      # muscle end of the last sub-step


def law_of(drive: LoadingServoModel) -> tuple[list[float], list[float]]:
    """(parameters in ``LAW_PARAMETERS`` order, state in ``DriveState`` order) of ``drive``."""
    params = [float(getattr(drive.p, n)) for n in LAW_PARAMETERS]
    state = DriveState(drive.phi, drive.w, drive.integral, drive.force_n, drive.encoder_rad,
                       drive.contraction_m)
    return params, list(state)


def drive_from_law(params: list[float], state: list[float], mode: int, setpoint: float,
                   cache: dict | None = None) -> LoadingServoModel:
    """A drive in the state a law describes (``cache`` reuses the drive of a parameter set).

    Raises:
        ModelError: the vectors do not have the lengths of ``LAW_PARAMETERS``/``DriveState``.
    """
    if len(params) != len(LAW_PARAMETERS) or len(state) != len(DriveState._fields):
        raise ModelError(f'drive law has {len(params)} parameters and {len(state)} state '
                         f'values; expected {len(LAW_PARAMETERS)} and '
                         f'{len(DriveState._fields)}')
    key = tuple(params)
    m = cache.get(key) if cache is not None else None
    if m is None:
        kw = {}
        for f, v in zip(dataclasses.fields(LoadingServoParams), params, strict=True):
            kind = {'bool': bool, 'int': int}.get(str(f.type), float)
            kw[f.name] = kind(v)
        m = LoadingServoModel(LoadingServoParams(**kw))
        if cache is not None:
            cache.clear()
            cache[key] = m
    m.mode, m.setpoint = LoadMode(mode), float(setpoint)
    s = DriveState(*state)
    m.phi, m.w, m.integral = s.angle_rad, s.rate_rad_s, s.integral
    m.force_n, m.encoder_rad, m.contraction_m = s.force_n, s.encoder_rad, s.contraction_m
    return m
