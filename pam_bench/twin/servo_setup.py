"""A scene's torque-servo setup for the twin, and the servo's run read back from a bag.

Both sides of a servo comparison start here: ``scene_servo_setup`` reads the scene's typed
settings (``config.settings``, the same the node reads) into the arguments of
``servo_bench.run_servo``; ``servo_run_of_bag`` turns the ``torque_servo/state`` topic of a
recorded run into the same ``ServoRun`` so the two compare sample for sample.
"""

from __future__ import annotations

import pathlib
from typing import Any

import numpy as np

from pam_bench.analysis.servo_bag import read_servo_states
from pam_bench.config.scene import Scene
from pam_bench.control.inverse import InverseModel
from pam_bench.control.torque_servo import Signal, SignalKind
from pam_bench.twin.servo_bench import ServoRun

__all__ = ['scene_servo_setup', 'servo_run_of_bag']


def scene_servo_setup(scene: Scene) -> dict[str, Any]:
    """The servo's settings in a scene.

    Returns:
        ``signal`` (Signal), ``angle_rad`` (rad, the angle the loading servo holds),
        ``muscles`` (1 or 2), ``params`` (TorqueServoParams), ``inverse`` (InverseModel or
        None), ``valve`` and ``muscle`` (the scene's valve_1 and muscle_1 models, which the
        twin gives every muscle), ``plugins`` (the controller plug-ins' settings).
    """
    st = scene.settings()
    ts, ls = st['torque_servo'], st['loading_servo']
    sig = Signal(SignalKind(ts.signal), ts.amplitude, ts.omega_rad_s, ts.offset, ts.period_s)
    if ts.muscles == 2:
        angle = ls.hold_angle_rad
    else:   # single muscle: the drive holds x = r theta
        angle = ls.initial_setpoint / (ts.servo.pitch_diameter_m / 2.0)
    model = ts.inverse_model_file
    return {'signal': sig, 'angle_rad': angle, 'muscles': ts.muscles, 'params': ts.servo,
            'inverse': InverseModel.load(model) if model else None,
            'valve': st['valve_1'].valve, 'muscle': st['muscle_1'].muscle,
            'plugins': ts.plugins}


def servo_run_of_bag(bag: pathlib.Path, muscles: int) -> ServoRun:
    """The servo's time series recorded in ``bag`` (``torque_servo/state``), time from 0 s.

    Args:
        bag: the bag directory.
        muscles: 1 or 2; columns of the per-muscle arrays kept.
    """
    s = read_servo_states(bag)
    t = s['t_s'] - s['t_s'][0]
    return ServoRun(t, s['torque_setpoint'], s['torque_measured'],
                    np.gradient(s['torque_setpoint'], t), s['force_setpoint'][:, :muscles],
                    s['force_measured'][:, :muscles], s['voltage'][:, :muscles],
                    s['u_feedforward'][:, :muscles], 'N m' if muscles == 2 else 'N')
