"""The controller plug-in point: a lab's own torque-servo law, without editing pam_bench.

A plug-in is a class declared in the entry-point group ``pam_bench.controllers``
(``vocabulary.plugins``). The torque servo makes one per muscle channel and calls it where a
built-in controller's feed-forward and PID would run, with the same inputs:

    step(dt_s, target, contraction_m, force_n) -> (u_feedforward V, u_feedback V)

``target`` is the channel's force set point and its first two time derivatives (N, N/s,
N/s^2: the torque split with the pretension, ``torque_servo.split_torque``), the contraction
is the channel's from the measured pulley angle (m), ``force_n`` its load cell's last reading
(N), ``dt_s`` the control period (s). The servo adds the two parts and clamps the sum to the
valve's range, as for the built-ins. The class declares its settings as a dataclass,
``settings`` (``vocabulary.params.field``: default, unit, range, text), which a scene sets by
path (``torque_servo.plugins.NAME.FIELD``), and is built as ``cls(settings, servo, inverse)``
with the servo's own parameters (``TorqueServoParams``) and the identified inverse model
(``control.inverse.InverseModel``, or None when the scene names none).

A plug-in that raises or returns a value that is not finite is a ``PluginFault`` naming it:
the node vents the valves and says so in one line, the bag stays valid.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Protocol

from pam_bench.vocabulary.errors import PamBenchError
from pam_bench.vocabulary.plugins import discover

__all__ = ['GROUP', 'Controller', 'PluginFault', 'controller_plugins', 'controller_class',
           'problem', 'call']

GROUP = 'pam_bench.controllers'


class Controller(Protocol):
    """What a controller plug-in is (module docstring)."""

    settings: type

    def reset(self) -> None:
        """Forget the loop's state (integrals, filters): the servo vented or restarts."""

    def step(self, dt_s: float, target: tuple[float, float, float], contraction_m: float,
             force_n: float) -> tuple[float, float]:
        """(feed-forward V, feedback V) of one control period."""


class PluginFault(PamBenchError, RuntimeError):
    """A controller plug-in raised or gave a value that is not finite (named)."""


def problem(obj: object) -> str:
    """Why a plug-in's object cannot be a controller ('' when it can)."""
    if not isinstance(obj, type):
        return f'not a class: {type(obj).__name__}'
    missing = [a for a in ('settings', 'step', 'reset') if not hasattr(obj, a)]
    if missing:
        return f'lacks {", ".join(missing)}'
    settings: Any = vars(obj).get('settings') or next(
        (vars(b)['settings'] for b in obj.__mro__ if 'settings' in vars(b)), None)
    if not (isinstance(settings, type) and dataclasses.is_dataclass(settings)):
        return 'settings is not a dataclass'
    return ''


def controller_plugins() -> dict[str, Any]:
    """Name -> class of every controller plug-in installed here that is one."""
    return {p.name: p.obj for p in discover(GROUP) if not problem(p.obj)}


def controller_class(name: str) -> Any:
    """The plug-in controller called ``name``, or None."""
    return controller_plugins().get(name)


def call(name: str, ctl: Any, dt_s: float, target: tuple[float, float, float],
         contraction_m: float, force_n: float) -> tuple[float, float]:
    """One step of the plug-in ``name``'s controller ``ctl``, checked.

    Raises:
        PluginFault: it raised, or its output is not two finite numbers.
    """
    try:
        ff, fb = ctl.step(dt_s, target, contraction_m, force_n)
        ff, fb = float(ff), float(fb)
    except Exception as exc:  # noqa: BLE001 - a lab's code: whatever it raises is its fault
        raise PluginFault(f'controller plug-in {name!r} raised {type(exc).__name__}: '
                          f'{str(exc).splitlines()[0][:120] if str(exc) else ""}') from None
    if not (math.isfinite(ff) and math.isfinite(fb)):
        raise PluginFault(f'controller plug-in {name!r} gave a voltage that is not finite '
                          f'({ff!r}, {fb!r})')
    return ff, fb
