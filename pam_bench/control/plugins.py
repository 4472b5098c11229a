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

A plug-in is usable when it loads, is such a class, and builds with its default settings
(``unusable`` says why not; ``pam-bench plugins`` lists it so). A scene that names one builds
it with the scene's settings before any node starts (``check_controller``). A plug-in that
raises or returns a value that is not finite while it runs is a ``PluginFault`` naming it: the
node vents the valves, says so in one line and ends the run as aborted; the bag stays valid.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, Protocol

from pam_bench.control.params import TorqueServoParams
from pam_bench.vocabulary.errors import PamBenchError
from pam_bench.vocabulary.plugins import Plugin, discover, plugin

__all__ = ['GROUP', 'Controller', 'PluginFault', 'controller_plugins', 'controller_class',
           'problem', 'unusable', 'check_controller', 'call']

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


def _built(cls: Any, settings: Any, what: str, servo: Any = None, inverse: Any = None) -> str:
    """Why ``cls`` cannot be built with ``settings`` (``what`` they are, for the message;
    '' when it can); ``servo`` None: the servo's default parameters."""
    if servo is None:
        servo = TorqueServoParams()
    try:
        cls(settings, servo, inverse)
    except Exception as exc:  # noqa: BLE001 - a lab's code: whatever it raises, named
        text = str(exc).splitlines()[0][:160] if str(exc) else ''
        return f'cannot be built with {what}: {type(exc).__name__}: {text}'
    return ''


def unusable(p: Plugin) -> str:
    """Why the controller plug-in ``p`` cannot run ('' when it can): it does not load, is not
    a controller class, or cannot be built with its default settings."""
    why = p.error or problem(p.obj)
    if why:
        return why
    try:
        defaults = p.obj.settings()
    except Exception as exc:  # noqa: BLE001 - a lab's settings class
        return f'its settings have no defaults: {type(exc).__name__}: {exc}'
    return _built(p.obj, defaults, 'its default settings')


def controller_plugins() -> dict[str, Any]:
    """Name -> class of every controller plug-in installed here that is usable."""
    return {p.name: p.obj for p in discover(GROUP) if not unusable(p)}


def check_controller(name: str, servo: Any, settings: Any = None, inverse: Any = None
                     ) -> None:
    """Build the plug-in controller ``name`` as the servo will (``servo``: its parameters,
    ``settings``: the plug-in's, None: its defaults), before any node starts; built-in names
    pass.

    Raises:
        PluginFault: it does not load, is not a controller, or cannot be built (named, with
            its package and the reason).
    """
    p = plugin(GROUP, name)
    if p is None:
        return
    why = p.error or problem(p.obj) or _built(
        p.obj, settings if settings is not None else p.obj.settings(), "the scene's settings",
        servo, inverse)
    if why:
        raise PluginFault(f'controller plug-in {name!r} (package {p.package}): {why}')


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
