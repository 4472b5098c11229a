"""A node's ROS parameters, declared from its settings dataclass (``config.settings``).

Every leaf of the settings becomes one declared parameter, sections joined by dots as in a
params file (``muscle.gain_exponent``), with a ``ParameterDescriptor`` that carries the text,
unit and range of its ``field``. The values rclpy resolved (params file, ``-p``, overrides)
are read back into the dataclass with ``vocabulary.params.from_mapping``, which checks type and
range and names a bad key; ``runtime.process.reject_undeclared`` refuses any key the class does
not have.
"""

from __future__ import annotations

from typing import Any, TypeVar

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.node import Node
from rclpy.parameter import Parameter

from pam_bench.vocabulary.params import ParamInfo, describe, flat_infos, from_mapping, get_path

__all__ = ['descriptor', 'declare_settings', 'overrides_of', 'ros_value']

T = TypeVar('T')


def descriptor(info: ParamInfo) -> ParameterDescriptor:
    """The ROS descriptor of one setting: description, and its range where it has one."""
    desc = ParameterDescriptor(description=describe(info))
    low, high = info.low, info.high
    if low is None and high is None:
        return desc
    if isinstance(info.default, float):
        desc.floating_point_range = [FloatingPointRange(
            from_value=float(low if low is not None else -1e300),
            to_value=float(high if high is not None else 1e300))]
    elif isinstance(info.default, int) and not isinstance(info.default, bool):
        desc.integer_range = [IntegerRange(from_value=int(low if low is not None else -2**62),
                                           to_value=int(high if high is not None else 2**62),
                                           step=0)]
    return desc


def ros_value(info: ParamInfo, value: Any) -> Any:
    """A setting's value as ROS holds it: an empty list of strings is ``['']`` (an empty list
    has no element type in ROS, and rclpy reads an empty override as a byte array); the node
    drops the empty strings again (``declare_settings``)."""
    if isinstance(info.default, list):
        return list(value) or ([''] if info.item is str else [])
    return value


def declare_settings(node: Node, cls: type[T]) -> T:
    """Declare every leaf of ``cls`` on ``node`` and return the settings it resolved.

    Raises:
        ParameterError: a value has the wrong type or is out of range (names the key).
    """
    nested: dict[str, Any] = {}
    for info in flat_infos(cls):
        value = node.declare_parameter(info.name, ros_value(info, info.default),
                                       descriptor(info)).value
        if isinstance(info.default, list):
            value = [v for v in value if v != ''] if info.item is str else list(value)
        here = nested
        parts = info.name.split('.')
        for part in parts[:-1]:
            here = here.setdefault(part, {})
        here[parts[-1]] = value
    return from_mapping(cls, nested, f'{node.get_name()}.')


def overrides_of(settings: Any) -> list[Parameter]:
    """Every leaf of a settings object as a ``Parameter`` override (a composed node is built
    with these instead of a params file), typed as the node declares it."""
    return [Parameter(info.name, value=ros_value(info, get_path(settings, info.name)))
            for info in flat_infos(type(settings))]
