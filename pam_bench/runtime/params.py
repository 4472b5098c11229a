"""A node's ROS parameters, declared from its settings dataclass (``config.settings``).

Every leaf of the settings becomes one declared parameter, sections joined by dots as in a
params file (``muscle.gain_exponent``), with a ``ParameterDescriptor`` that carries the text,
unit and range of its ``field``. The values rclpy resolved (params file, ``-p``, overrides)
are read back into the dataclass with ``vocabulary.params.from_mapping``, which checks type and
range and names a bad key; ``runtime.process.reject_undeclared`` refuses any key the class does
not have.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any, TypeVar

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.node import Node
from rclpy.parameter import Parameter

from pam_bench.vocabulary.params import ParamInfo, describe, flat_infos, from_mapping, get_path

__all__ = ['descriptor', 'declare_settings', 'overrides_of', 'ros_value', 'wildcard_only_keys']

T = TypeVar('T')


def descriptor(info: ParamInfo) -> ParameterDescriptor:
    """The ROS descriptor of one setting: description, its range where it has one, and
    read-only unless the setting is tunable (``runtime.tuning``)."""
    desc = ParameterDescriptor(description=describe(info), read_only=not info.tunable)
    low, high = info.low, info.high
    if low is None and high is None:
        return desc
    if info.off is not None and low is not None:        # ROS ranges have no gap
        low = min(low, info.off)
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


def _sections(tree: Any, path: tuple[str, ...] = ()) -> Iterator[tuple[tuple[str, ...], Any]]:
    """The node sections of an rcl params file: (node path, its ``ros__parameters``)."""
    if not isinstance(tree, dict):
        return
    for key, value in tree.items():
        if key == 'ros__parameters':
            yield path, value
        else:
            yield from _sections(value, (*path, *str(key).strip('/').split('/')))


def _flat(params: Any, prefix: str = '') -> Iterator[str]:
    if isinstance(params, dict):
        for key, value in params.items():
            yield from _flat(value, f'{prefix}{key}.')
    else:
        yield prefix[:-1]


def wildcard_only_keys(args: list[str]) -> set[str]:
    """The parameter keys that reach a node only through a wildcard section (``/**:``,
    ``/*/name`` is the node's own) of the ``--params-file`` files in ``args``: a file shared
    by several nodes may set a key one of them does not have, which that node then ignores
    with a warning instead of refusing to start.

    Args:
        args: the process's arguments (the ROS ones after ``--ros-args``).

    Raises:
        InputError: a params file cannot be read or parsed (rclpy has read it already).
    """
    import pathlib

    from pam_bench.vocabulary.yaml_io import read_yaml
    files = [args[i + 1] for i, a in enumerate(args[:-1]) if a == '--params-file']
    own: set[str] = {a.split(':=', 1)[0] for i, a in enumerate(args[1:], 1)
                     if args[i - 1] == '-p' and ':=' in a}
    wild: set[str] = set()
    for path in files:
        tree = read_yaml(pathlib.Path(path))
        for node_path, params in _sections(tree):
            keys = set(_flat(params))
            (wild if node_path and '*' in node_path[-1] else own).update(keys)
    return wild - own
