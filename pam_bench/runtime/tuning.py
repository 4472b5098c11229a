"""Settings a running node takes: ``set_parameters`` on a tunable setting, applied at a safe point.

A setting is tunable when its ``field`` says so (``vocabulary.params.field(tunable=True)``):
the servo's gains and set point, the stale timeout, the status and diagnostics periods, the
suspenders. Every other parameter is declared read-only (``runtime.params.descriptor``), so
rclpy refuses a change with "read-only" and the node keeps what it started with (a channel, a
muscle count or a file path changed under a running node would mean something else than what
its outputs say).

A change is checked at once (type, range, and whatever the node checks in ``check_tuning``)
and refused with the reason in the ``SetParametersResult``; an accepted one waits for the
node's next step (``apply_tuning``), where the node takes it in ``on_tuned``: never halfway
through a step. A lock-step node starts without parameter services (``runtime.base``): a
simulated run stays reproducible from its scene.
"""

from __future__ import annotations

from typing import Any

from rcl_interfaces.msg import SetParametersResult
from rclpy.parameter import Parameter

from pam_bench.runtime.core import NodeCore
from pam_bench.vocabulary.errors import ParameterError
from pam_bench.vocabulary.params import ParamInfo, flat_infos, get_path, with_path

__all__ = ['Tuning']


def _value(info: ParamInfo, param: Parameter) -> Any:
    """A parameter's value as its setting holds it (``runtime.params.ros_value`` undone)."""
    value = param.value
    if isinstance(info.default, list):
        return [v for v in value if v != ''] if info.item is str else list(value)
    if isinstance(info.default, float) and isinstance(value, int) and \
            not isinstance(value, bool):
        return float(value)
    return value


class Tuning(NodeCore):
    """The on-set callback of a bench node and the safe point that applies it."""

    _tuned: tuple[Any, list[str]] | None

    def _init_tuning(self) -> None:
        """Install the on-set callback (after the parameters are declared: rclpy calls it on
        declarations too)."""
        self._tuned = None
        self._infos = {i.name: i for i in flat_infos(type(self.settings))}
        self.add_on_set_parameters_callback(self._on_set_parameters)

    def _on_set_parameters(self, params: list[Parameter]) -> SetParametersResult:
        """Check a change of tunable settings; keep it for the next step or refuse it."""
        new, names = self._tuned if self._tuned is not None else (self.settings, [])
        for param in params:
            info = self._infos.get(param.name)
            if info is None:               # rclpy's own (use_sim_time): not ours to judge
                continue
            if not info.tunable:
                return SetParametersResult(successful=False, reason=f'{param.name} is '
                                           'read-only: set it when the node starts')
            try:
                new = with_path(new, param.name, _value(info, param))
            except ParameterError as exc:
                return SetParametersResult(successful=False, reason=str(exc))
            names.append(param.name)
        if names:
            reason = self.check_tuning(new, names)
            if reason:
                return SetParametersResult(successful=False, reason=reason)
            self._tuned = (new, names)
        return SetParametersResult(successful=True)

    def apply_tuning(self) -> None:
        """At a safe point (the start of a step): take the settings accepted since the last
        one (``on_tuned``) and log what changed."""
        if self._tuned is None:
            return
        (new, names), self._tuned = self._tuned, None
        old, self.settings = self.settings, new
        self.diagnostics.period_ns = round(float(getattr(new, 'diagnostics_period_s', 0.0))
                                           * 1e9)
        self.on_tuned(old, sorted(set(names)))
        shown = ', '.join(f'{n} {get_path(old, n)!r} -> {get_path(new, n)!r}'
                          for n in sorted(set(names)))
        self.get_logger().info(f'settings changed: {shown}')

    # --- to override -------------------------------------------------------------------
    def check_tuning(self, new: Any, names: list[str]) -> str:
        """Why the node cannot take ``new`` now ('' when it can); called when a change is
        asked for."""
        return ''

    def on_tuned(self, old: Any, names: list[str]) -> None:
        """Take the new ``self.settings`` (``names`` changed since ``old``)."""
