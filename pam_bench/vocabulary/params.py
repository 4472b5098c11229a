"""Typed settings: one dataclass per model or node, every field with unit, range and meaning.

A field is declared once, with ``field(default, unit, text, low, high, choices)``; a group of
settings that belongs to one model is a ``section`` (a nested dataclass). The same metadata
serves every consumer: the YAML loaders (one clear message naming a bad key and the nearest
known one), the ROS nodes (each leaf becomes a declared parameter with a
``ParameterDescriptor``, sections joined by dots, as in a params file), the twin and truth
(the objects themselves) and sweeps, which address a leaf by its dotted path
(``muscle.gain_exponent`` inside a node, ``muscle_1.muscle.gain_exponent`` in a scene).
"""

from __future__ import annotations

import copy
import dataclasses
import difflib
import math
from collections.abc import Iterable, Mapping
from typing import Any, TypeVar

from pam_bench.vocabulary.errors import ParameterError, quoted, shorten

__all__ = ['field', 'section', 'from_mapping', 'to_mapping', 'merged', 'with_path', 'get_path',
           'describe', 'ParamInfo', 'param_infos', 'flat_infos', 'sections', 'validate',
           'check_known', 'nearest', 'hint', 'deep_merge', 'leaf_paths']

T = TypeVar('T')


@dataclasses.dataclass(frozen=True)
class ParamInfo:
    """What a setting means: name (dotted inside sections), default, unit, allowed range or
    choices, one line of text, and the element type of a list (``float`` or ``str``)."""

    name: str
    default: Any
    unit: str
    low: float | None
    high: float | None
    text: str
    choices: tuple[str, ...] = ()
    item: type = float
    tunable: bool = False
    off: float | None = None


def field(default: Any, unit: str, text: str, low: float | None = None,
          high: float | None = None, choices: Iterable[str] = (), item: type = float,
          tunable: bool = False, off: float | None = None) -> Any:
    """A dataclass field with unit, range (or the strings it may take) and description in its
    metadata; ``item`` is the element type of a list setting (``float`` or ``str``);
    ``tunable``: a running node takes a new value (``set_parameters``, ``runtime.tuning``),
    else its ROS parameter is read-only; ``off``: a value outside the range that turns what
    the setting sets off (a file split by size: 0, never)."""
    meta = {'unit': unit, 'low': low, 'high': high, 'text': text,
            'choices': tuple(choices), 'item': item, 'tunable': tunable, 'off': off}
    if isinstance(default, list):
        return dataclasses.field(default_factory=lambda: list(default), metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def section(cls: type, text: str) -> Any:
    """A nested settings dataclass (a model's parameters inside a node's settings)."""
    return dataclasses.field(default_factory=cls, metadata={'section': cls, 'text': text})


def _section_of(f: dataclasses.Field) -> type | None:
    return f.metadata.get('section')


def sections(cls: type) -> dict[str, type]:
    """Name -> dataclass of every section of ``cls``."""
    return {f.name: s for f in dataclasses.fields(cls) if (s := _section_of(f)) is not None}


def _info(f: dataclasses.Field, name: str) -> ParamInfo:
    factory: Any = f.default_factory
    default = f.default if f.default is not dataclasses.MISSING else factory()
    m = f.metadata
    return ParamInfo(name, default, m.get('unit', ''), m.get('low'), m.get('high'),
                     m.get('text', ''), tuple(m.get('choices', ())), m.get('item', float),
                     bool(m.get('tunable', False)), m.get('off'))


def param_infos(cls: type) -> list[ParamInfo]:
    """The ``ParamInfo`` of every leaf field of ``cls`` (sections left out), in order."""
    return [_info(f, f.name) for f in dataclasses.fields(cls) if _section_of(f) is None]


def flat_infos(cls: type, prefix: str = '') -> list[ParamInfo]:
    """Every leaf of ``cls`` and of its sections, named by dotted path, in order."""
    out = []
    for f in dataclasses.fields(cls):
        sec = _section_of(f)
        if sec is None:
            out.append(_info(f, prefix + f.name))
        else:
            out += flat_infos(sec, f'{prefix}{f.name}.')
    return out


def leaf_paths(cls: type) -> list[str]:
    """Dotted paths of every leaf of ``cls``."""
    return [i.name for i in flat_infos(cls)]


def describe(info: ParamInfo) -> str:
    """One line for a ParameterDescriptor: meaning, unit and range (or choices)."""
    rng = ''
    if info.low is not None or info.high is not None:
        rng = f' range [{info.low if info.low is not None else "-inf"}, ' \
              f'{info.high if info.high is not None else "inf"}]'
        if info.off is not None:
            rng += f' or {info.off:g} (off)'
    if info.choices:
        rng = f' one of {", ".join(info.choices)}'
    return f'{info.text} (unit: {info.unit or "-"}){rng}'


def _check_value(prefix: str, info: ParamInfo, value: Any) -> Any:
    key = f'{prefix}{info.name}'
    default = info.default
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise ParameterError(f'parameter {key!r}: expected true/false, got {shorten(value)}')
        return value
    if isinstance(default, str):
        if not isinstance(value, str):
            raise ParameterError(f'parameter {key!r}: expected a string, got {shorten(value)}')
        if info.choices and value not in info.choices:
            raise ParameterError(f'parameter {key!r}: {shorten(value)} is not one of '
                                 f'{", ".join(info.choices)} ({hint(value, info.choices)})')
        return value
    if isinstance(default, list):
        if info.item is str:
            if not isinstance(value, (list, tuple)) or not all(isinstance(v, str)
                                                               for v in value):
                raise ParameterError(f'parameter {key!r}: expected a list of strings, got '
                                     f'{shorten(value)}')
            return [str(v) for v in value]
        if not isinstance(value, (list, tuple)) or not all(
                isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
            raise ParameterError(f'parameter {key!r}: expected a list of numbers, got '
                                 f'{shorten(value)}')
        vals = [float(v) for v in value]
        for v in vals:
            _check_range(key, info, v)
        return vals
    if isinstance(default, int):
        if not isinstance(value, int) or isinstance(value, bool):
            raise ParameterError(f'parameter {key!r}: expected an integer, got {shorten(value)}')
        _check_range(key, info, value)
        return value
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        raise ParameterError(f'parameter {key!r}: expected a number, got {shorten(value)}')
    value = float(value)
    _check_range(key, info, value)
    return value


def _check_range(key: str, info: ParamInfo, value: float) -> None:
    if not math.isfinite(value):
        raise ParameterError(f'parameter {key!r}: {shorten(value)} is not a finite number')
    if info.off is not None and value == info.off:
        return
    if info.low is not None and value < info.low:
        raise ParameterError(f'parameter {key!r}: {value} is below its minimum {info.low} '
                             f'{info.unit}' + (f' (or {info.off:g}: off)'
                                               if info.off is not None else ''))
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
    unknown = sorted(set(keys) - set(known), key=str)
    if not unknown:
        return
    key = unknown[0]
    raise ParameterError(f'{where}: unknown key {quoted(prefix + str(key))} '
                         f'({hint(str(key), known, prefix)})')


def from_mapping(cls: type[T], values: Mapping[str, Any] | None, prefix: str = '') -> T:
    """Build a settings dataclass from a (nested) mapping, checking every value.

    Args:
        cls: the settings dataclass.
        values: key -> value, a section's key -> mapping; missing keys take the default.
        prefix: shown in front of key names in error messages (e.g. ``'muscle_1.'``).

    Raises:
        ParameterError: an unknown key, a wrong type or a value out of range, naming the key
            by its whole path and the nearest known key.
    """
    values = dict(values or {})
    fields = {f.name: f for f in dataclasses.fields(cls)}   # type: ignore[arg-type]
    unknown = sorted(set(values) - set(fields), key=str)
    if unknown:
        raise ParameterError(f'unknown setting {quoted(prefix + str(unknown[0]))} '
                             f'({hint(str(unknown[0]), fields, prefix)})')
    kwargs = {}
    for k, v in values.items():
        sec = _section_of(fields[k])
        if sec is None:
            kwargs[k] = _check_value(prefix, _info(fields[k], k), v)
        elif isinstance(v, sec):
            validate(v, f'{prefix}{k}.')
            kwargs[k] = copy.deepcopy(v)
        elif isinstance(v, Mapping):
            kwargs[k] = from_mapping(sec, v, f'{prefix}{k}.')
        else:
            raise ParameterError(f'parameter {prefix}{k!r}: expected a mapping of '
                                 f'{sec.__name__} settings, got {shorten(v)}')
    return cls(**kwargs)


def to_mapping(obj: Any) -> dict[str, Any]:
    """The nested mapping of a settings object (plain values: what a params file holds)."""
    out: dict[str, Any] = {}
    for f in dataclasses.fields(obj):
        v = getattr(obj, f.name)
        out[f.name] = to_mapping(v) if _section_of(f) is not None else (
            list(v) if isinstance(v, (list, tuple)) else v)
    return out


def deep_merge(dst: dict[str, Any], src: Mapping[str, Any]) -> dict[str, Any]:
    """Merge ``src`` into ``dst`` in place, mappings key by key; returns ``dst``."""
    for k, v in src.items():
        if isinstance(v, Mapping) and isinstance(dst.get(k), dict):
            deep_merge(dst[k], v)
        else:
            dst[k] = copy.deepcopy(v)
    return dst


def merged(obj: T, values: Mapping[str, Any] | None, prefix: str = '') -> T:
    """A copy of ``obj`` with the (nested) ``values`` over it, every value checked.

    Raises:
        ParameterError: as ``from_mapping``.
    """
    if not values:
        return copy.deepcopy(obj)
    return from_mapping(type(obj), deep_merge(to_mapping(obj), values), prefix)


def _split(cls: type, path: str, prefix: str) -> tuple[list[str], type]:
    """The parts of a dotted ``path`` inside ``cls``, checked; and the class holding the leaf."""
    parts = path.split('.')
    here = cls
    for i, part in enumerate(parts):
        fields = {f.name: f for f in dataclasses.fields(here)}
        if part not in fields:
            done = '.'.join(parts[:i])
            known = [p for p in leaf_paths(here)]
            full = f'{prefix}{done + "." if done else ""}'
            raise ParameterError(f'unknown setting {quoted(prefix + path)} '
                                 f'({hint(".".join(parts[i:]), known, full)})')
        sec = _section_of(fields[part])
        last = i == len(parts) - 1
        if sec is None and not last:
            raise ParameterError(f'unknown setting {quoted(prefix + path)}: '
                                 f"'{prefix}{'.'.join(parts[:i + 1])}' is a value, not a section")
        if sec is not None and last:
            raise ParameterError(f'setting {quoted(prefix + path)} is a section: name one of its '
                                 f'values ({", ".join(leaf_paths(sec))})')
        if sec is not None:
            here = sec
    return parts, here


def get_path(obj: Any, path: str, prefix: str = '') -> Any:
    """The value of the leaf at the dotted ``path``.

    Raises:
        ParameterError: no such leaf (named, with the nearest known path).
    """
    parts, _ = _split(type(obj), path, prefix)
    for part in parts:
        obj = getattr(obj, part)
    return obj


def with_path(obj: T, path: str, value: Any, prefix: str = '') -> T:
    """A copy of ``obj`` with the leaf at the dotted ``path`` set to ``value`` (checked).

    Raises:
        ParameterError: no such leaf, or a value of the wrong type or out of range.
    """
    parts, _ = _split(type(obj), path, prefix)
    nested: dict[str, Any] = {}
    here = nested
    for part in parts[:-1]:
        here = here.setdefault(part, {})
    here[parts[-1]] = value
    return merged(obj, nested, prefix)


def validate(obj: Any, prefix: str = '') -> None:
    """Check every field of an existing settings object (types and ranges), sections too."""
    for f in dataclasses.fields(obj):
        sec = _section_of(f)
        if sec is None:
            _check_value(prefix, _info(f, f.name), getattr(obj, f.name))
        else:
            validate(getattr(obj, f.name), f'{prefix}{f.name}.')
