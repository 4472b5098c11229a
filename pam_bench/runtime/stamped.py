"""Stamped message objects built by filling rosidl's value slots instead of its constructors.

A composed lock-step run builds a dozen stamped messages per exchange (the valve's pressure
and samples, the muscle's state and samples, the encoder's and the loading servo's joint
states, the commands...), half a million in a full campaign. rosidl's keyword constructor
imports its nested classes, builds a default Header and Time, then replaces them through the
property setters: about 4.5 us for a MuscleState with its stamp on this machine. ``stamped``
builds the same object (the same slot values the constructor and setters leave with field
checks off, rosidl's default) in about 1 us, from a function generated once per class from
``get_fields_and_field_types()``, the way ``runtime.cdr`` generates its encoders:

* numeric sequences become ``array.array`` of rosidl's type code (an array of that code is
  kept as it is), other sequences and strings are stored as given, numbers as given;
* fixed-size numeric arrays become numpy arrays of that type, as rosidl's setters make them
  (its constructor's zeros when not given; the length is not checked, as rosidl does not
  with field checks off);
* a nested message not given is built with its own constructor (rare: the bench's messages
  nest only their Header);
* an unknown field name raises ``TypeError`` (rosidl checks names only with
  ``ROS_PYTHON_CHECK_FIELDS=1``).

A class with a field type the generator does not handle (fixed-size arrays of strings or
booleans; ``char``/``octet`` sequences), or without rosidl's slots, falls back to the
constructor and the setters. Receivers must not change what they get: every message of one
tick may share one Time object.
"""

from __future__ import annotations

import array
import functools
import math
from collections.abc import Callable
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from std_msgs.msg import Header

from pam_bench.runtime.cdr import ARRAY_CODES, element_of, fields_of
from pam_bench.runtime.messages import time_of

__all__ = ['joint_position', 'joint_effort', 'stamped', 'header_of']

_NUMBERS = {'float': '0.0', 'double': '0.0', 'boolean': 'False',
            **{k: '0' for k in ('int8', 'uint8', 'int16', 'uint16', 'int32', 'uint32', 'int64',
                                'uint64')}}
_HEADER_OK = all(f'_{n}' in cls.__slots__ for cls, names in (
    (Time, ('sec', 'nanosec')), (Header, ('stamp', 'frame_id'))) for n in (*names, 'check_fields'))


def header_of(t_ns: int, frame_id: str) -> Header:
    """A Header stamped ``t_ns`` (ns; its Time shared with every message of that tick)."""
    h = object.__new__(Header)
    h._check_fields = False
    h._stamp = time_of(t_ns)
    h._frame_id = frame_id
    return h


def _numeric_array(value: Any, code: str) -> array.array:
    if type(value) is array.array and value.typecode == code:
        return value
    return array.array(code, value)


@functools.cache
def _builder(cls: type) -> Callable[..., Any] | None:
    """The generated builder of ``cls`` (module docstring), or None to use the constructor."""
    import importlib
    slots = set(getattr(cls, '__slots__', ()))
    fields = fields_of(cls)
    if (not _HEADER_OK or fields.get('header') != 'std_msgs/Header' or '_check_fields' not in slots
            or any(f'_{n}' not in slots for n in fields)):
        return None
    params, lines = [], []
    scope: dict[str, Any] = {'_new': object.__new__, '_cls': cls, '_header': header_of,
                             '_arr': _numeric_array, '_zeros': np.zeros, '_array': np.array}
    for name, kind in fields.items():
        if name == 'header':
            continue
        base, fixed, is_seq = element_of(kind)
        if fixed is not None:
            if base not in ARRAY_CODES:
                return None
            scope[f'_dt_{name}'] = np.dtype(ARRAY_CODES[base])
            params.append(f'{name}=None')
            lines.append(f'    m._{name} = _zeros({fixed}, _dt_{name}) if {name} is None '
                         f'else _array({name}, _dt_{name})')
        elif is_seq and base in ARRAY_CODES:
            code = ARRAY_CODES[base]
            params.append(f'{name}=None')
            lines.append(f'    m._{name} = _arr((), {code!r}) if {name} is None '
                         f'else _arr({name}, {code!r})')
        elif is_seq and (base.startswith('string') or '/' in base):
            params.append(f'{name}=None')
            lines.append(f'    m._{name} = [] if {name} is None else {name}')
        elif is_seq:
            return None
        elif base in _NUMBERS:
            params.append(f'{name}={_NUMBERS[base]}')
            lines.append(f'    m._{name} = {name}')
        elif base.startswith('string'):
            params.append(f"{name}=''")
            lines.append(f'    m._{name} = {name}')
        elif '/' in base:
            pkg, typ = base.split('/')
            try:
                scope[f'_C_{name}'] = getattr(importlib.import_module(f'{pkg}.msg'), typ)
            except (ImportError, AttributeError):
                return None
            params.append(f'{name}=None')
            lines.append(f'    m._{name} = _C_{name}() if {name} is None else {name}')
        else:
            return None
    sig = ', '.join(['t_ns', 'frame_id', *(['*'] if params else []), *params])
    src = '\n'.join([f'def build({sig}):', '    m = _new(_cls)', '    m._check_fields = False',
                     '    m._header = _header(t_ns, frame_id)', *lines, '    return m'])
    exec(compile(src, f'<stamped {cls.__name__}>', 'exec'), scope)  # noqa: S102 (generated)
    fn: Callable[..., Any] = scope['build']
    return fn


def stamped(cls: type, t_ns: int, frame_id: str = '', **fields: Any) -> Any:
    """A message of ``cls`` with ``header`` stamped ``t_ns`` (ns) and ``frame_id``, and the
    other fields from ``fields`` (their defaults otherwise); module docstring."""
    build = _builder(cls)
    if build is not None:
        return build(t_ns, frame_id, **fields)
    msg = cls(**fields)
    msg.header.stamp = time_of(t_ns)
    msg.header.frame_id = frame_id
    return msg


def joint_position(msg: Any, name: str) -> float:
    """The position of the joint ``name`` in a JointState (rad), read by name: a driver may
    publish several joints in any order. An unnamed message with one position counts as that
    joint; a missing joint, an empty message or a position list shorter than the names gives
    NaN (the caller rejects it, it does not crash)."""
    return _joint_value(msg, name, 'position')


def joint_effort(msg: Any, name: str) -> float:
    """The effort of the joint ``name`` in a JointState (N m for a revolute joint), read by
    name as ``joint_position`` reads the position (NaN where that gives NaN)."""
    return _joint_value(msg, name, 'effort')


def _joint_value(msg: Any, name: str, field: str) -> float:
    names = list(getattr(msg, 'name', []) or [])
    values = getattr(msg, field, None)
    if values is None:
        return math.nan
    try:
        if name in names:
            i = names.index(name)
            return float(values[i]) if i < len(values) else math.nan
        if not names and len(values) == 1:
            return float(values[0])
    except (TypeError, ValueError):
        return math.nan
    return math.nan
