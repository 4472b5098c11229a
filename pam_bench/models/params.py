"""Typed parameter sets: one dataclass per model, every field with unit, range and meaning.

The same metadata serves the YAML loader (clear message naming a bad key) and the ROS nodes
(each field becomes a declared parameter with a ``ParameterDescriptor``).
"""

from __future__ import annotations

import dataclasses
import difflib
import math
from collections.abc import Iterable, Mapping
from typing import Any, TypeVar

from pam_bench.models.errors import ParameterError

__all__ = ['field', 'from_mapping', 'describe', 'ParamInfo', 'param_infos', 'validate',
           'check_known', 'nearest', 'hint']

T = TypeVar('T')


@dataclasses.dataclass(frozen=True)
class ParamInfo:
    """What a parameter means: name, default, unit, allowed range and one line of text."""

    name: str
    default: Any
    unit: str
    low: float | None
    high: float | None
    text: str


def field(default: Any, unit: str, text: str, low: float | None = None,
          high: float | None = None) -> Any:
    """A dataclass field with unit, range and description in its metadata."""
    meta = {'unit': unit, 'low': low, 'high': high, 'text': text}
    if isinstance(default, list):
        return dataclasses.field(default_factory=lambda: list(default), metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def param_infos(cls: type) -> list[ParamInfo]:
    """The ``ParamInfo`` of every field of a parameter dataclass, in declaration order."""
    out = []
    for f in dataclasses.fields(cls):
        default = (f.default if f.default is not dataclasses.MISSING
                   else f.default_factory())  # type: ignore[operator]
        out.append(ParamInfo(f.name, default, f.metadata.get('unit', ''), f.metadata.get('low'),
                             f.metadata.get('high'), f.metadata.get('text', '')))
    return out


def describe(info: ParamInfo) -> str:
    """One line for a ParameterDescriptor: meaning, unit and range."""
    rng = ''
    if info.low is not None or info.high is not None:
        rng = f' range [{info.low if info.low is not None else "-inf"}, ' \
              f'{info.high if info.high is not None else "inf"}]'
    return f'{info.text} (unit: {info.unit or "-"}){rng}'


def _check_value(prefix: str, info: ParamInfo, value: Any) -> Any:
    key = f'{prefix}{info.name}'
    default = info.default
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise ParameterError(f'parameter {key!r}: expected true/false, got {value!r}')
        return value
    if isinstance(default, str):
        if not isinstance(value, str):
            raise ParameterError(f'parameter {key!r}: expected a string, got {value!r}')
        return value
    if isinstance(default, list):
        if not isinstance(value, (list, tuple)) or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
            raise ParameterError(f'parameter {key!r}: expected a list of numbers, got {value!r}')
        vals = [float(v) for v in value]
        for v in vals:
            _check_range(key, info, v)
        return vals
    if isinstance(default, int):
        if not isinstance(value, int) or isinstance(value, bool):
            raise ParameterError(f'parameter {key!r}: expected an integer, got {value!r}')
        _check_range(key, info, value)
        return value
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        raise ParameterError(f'parameter {key!r}: expected a number, got {value!r}')
    value = float(value)
    _check_range(key, info, value)
    return value


def _check_range(key: str, info: ParamInfo, value: float) -> None:
    if not math.isfinite(value):
        raise ParameterError(f'parameter {key!r}: {value!r} is not a finite number')
    if info.low is not None and value < info.low:
        raise ParameterError(f'parameter {key!r}: {value} is below its minimum {info.low} '
                             f'{info.unit}')
    if info.high is not None and value > info.high:
        raise ParameterError(f'parameter {key!r}: {value} is above its maximum {info.high} '
                             f'{info.unit}')


def nearest(name: str, known: Iterable[str]) -> str | None:
    """The known name closest to ``name`` (a likely misspelling), or None."""
    close = difflib.get_close_matches(name, list(known), n=1, cutoff=0.6)
    return close[0] if close else None


def hint(name: str, known: Iterable[str], prefix: str = '') -> str:
    """What to tell a user who wrote ``name``: the nearest known name, else all of them."""
    known = list(known)
    near = nearest(name, known)
    return (f"did you mean '{prefix}{near}'?" if near
            else f'known: {", ".join(sorted(known))}')


def check_known(keys: Iterable[str], known: Iterable[str], where: str, prefix: str = '') -> None:
    """Raise on the first key (sorted) that is not in ``known``.

    Args:
        keys: the keys given.
        known: the keys allowed.
        where: what holds them, for the message (e.g. ``"scene demo.yaml, parameters"``).
        prefix: put in front of the key and the suggestion (e.g. ``"muscle_1.muscle."``).

    Raises:
        ParameterError: names the unknown key and the nearest known one.
    """
    known = list(known)
    unknown = sorted(set(keys) - set(known))
    if not unknown:
        return
    key = unknown[0]
    raise ParameterError(f"{where}: unknown key '{prefix}{key}' ({hint(key, known, prefix)})")


def from_mapping(cls: type[T], values: Mapping[str, Any] | None, prefix: str = '') -> T:
    """Build a parameter dataclass from a mapping, checking every value against its field.

    Args:
        cls: the parameter dataclass.
        values: key -> value; missing keys take the default.
        prefix: shown in front of key names in error messages (e.g. ``'muscle.'``).

    Raises:
        ParameterError: an unknown key, a wrong type or a value out of range, naming the key.
    """
    values = dict(values or {})
    infos = {i.name: i for i in param_infos(cls)}
    check_known(values, infos, f'parameters of {cls.__name__}', prefix)
    kwargs = {k: _check_value(prefix, infos[k], v) for k, v in values.items()}
    return cls(**kwargs)


def validate(obj: Any, prefix: str = '') -> None:
    """Check every field of an existing parameter object (types and ranges)."""
    for info in param_infos(type(obj)):
        _check_value(prefix, info, getattr(obj, info.name))
