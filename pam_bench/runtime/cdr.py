"""CDR bytes of rclpy message objects, built with ``struct`` instead of rclpy's serialisation.

The composed recorder writes message objects it receives in process (``runtime.intra``) into the
bag, so it must serialise each one. ``rclpy.serialization.serialize_message`` converts the
object field by field into a C struct first and then serialises it, about 8 us per small
message on this machine; a 1 kHz step record of the campaign brings 680 thousand of them. The
encoder here is generated once per message class from ``get_fields_and_field_types()`` and
packs each run of fixed-size fields with one ``struct.Struct`` chosen by the run's start offset
modulo 8 (CDR aligns every number to its own size, at most 8, counted from the end of the
4-byte encapsulation header), so a WrenchStamped costs about 1 us.

The bytes are little-endian plain CDR (encapsulation ``00 01``) exactly as a reader of the bag
expects them: a sequence's element alignment is applied only when it has elements, and a
message that ends in a sequence of 8-byte numbers or of messages, a nested message or an
array is padded to 4 bytes with the pad count in the options byte (``ends_padded``;
``Recorder._cdr`` says why); padding bytes are zero. Field types the generator does not handle
(``char``, ``wstring``, fixed arrays of strings or messages) make ``encoder`` return None, and
the caller keeps rclpy's serialisation. Fields are read from the slots behind rosidl's
properties (``_name``) where the class has them.
"""

from __future__ import annotations

import array
import functools
import importlib
import struct
from collections.abc import Callable
from typing import Any

__all__ = ['fields_of', 'element_of', 'ARRAY_CODES', 'encoder', 'ends_padded', 'clock_cdr',
           'force_readings_cdr', 'trim_rule', 'TRIM_NEVER', 'TRIM_ALWAYS']

Encoder = Callable[[Any], bytes]

_FORMATS = {'boolean': '?', 'octet': 'c', 'uint8': 'B', 'int8': 'b', 'int16': 'h',
            'uint16': 'H', 'int32': 'i', 'uint32': 'I', 'int64': 'q', 'uint64': 'Q',
            'float': 'f', 'double': 'd'}
_WIDE = {'double', 'int64', 'uint64'}
ARRAY_CODES = {k: f for k, f in _FORMATS.items() if f in 'bBhHiIqQfd'}
"""rosidl type -> the ``array.array`` type code rosidl keeps a sequence of it in."""
# octet (byte) fields are 1-byte bytes objects in rclpy, hence 'c'
_HEADER = b'\x00\x01\x00\x00'
_ZEROS = tuple(bytes(n) for n in range(8))
_U32 = struct.Struct('<I').pack


class _Unsupported(Exception):
    """A field type the generator leaves to rclpy."""



def fields_of(cls: Any) -> dict[str, str]:
    """Field name -> rosidl type string of a message class, in order."""
    return dict(cls.get_fields_and_field_types())

def _class_of(kind: str) -> type:
    pkg, name = kind.split('/')
    return getattr(importlib.import_module(f'{pkg}.msg'), name)


def element_of(kind: str) -> tuple[str, int | None, bool]:
    """(element type, fixed length or None, is a sequence) of a field type string."""
    if kind.startswith('sequence<'):
        return kind[9:-1].split(',')[0].strip(), None, True
    if kind.endswith(']'):
        base, _, n = kind[:-1].partition('[')
        return base, int(n), False
    return kind, None, False


class _Gen:
    """Writes the body of one encoder function (module docstring)."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.consts: dict[str, Any] = {}
        self.run: list[tuple[str, str]] = []      # (expression, struct format) of fixed fields
        self.n = 0

    def name(self, value: Any) -> str:
        self.n += 1
        key = f'_c{self.n}'
        self.consts[key] = value
        return key

    def flush(self, ind: str) -> None:
        if not self.run:
            return
        structs = []
        for start in range(8):
            fmt, off = '<', start
            for _, f in self.run:
                pad = -off % struct.calcsize(f[0])     # an array aligns as its element
                fmt += 'x' * pad + f
                off += pad + struct.calcsize(f)
            structs.append(struct.Struct(fmt))
        s = self.name(tuple(structs))
        args = ', '.join(e for e, _ in self.run)
        self.lines.append(f'{ind}b += {s}[(len(b) - 4) & 7].pack({args})')
        self.run = []

    def message(self, cls: type, expr: str, ind: str) -> None:
        slots = set(getattr(cls, '__slots__', ()))
        for field, kind in fields_of(cls).items():
            # rosidl keeps a field's value in the slot _field behind a property: read the slot
            attr = f'_{field}' if f'_{field}' in slots else field
            self.field(kind, f'{expr}.{attr}', ind)

    def field(self, kind: str, expr: str, ind: str) -> None:
        base, n, is_seq = element_of(kind)
        if base in _FORMATS and not is_seq:
            self.run.append((expr if n is None else f'*{expr}', _FORMATS[base] * (n or 1)))
            return
        if n is not None:
            raise _Unsupported(kind)
        if '/' in base and not is_seq:
            self.message(_class_of(base), expr, ind)
            return
        self.flush(ind)
        v = f'v{len(self.lines)}'
        self.lines.append(f'{ind}{v} = {expr}')
        if base.startswith('string') and not is_seq:
            self.lines += [f'{ind}{v} = {v}.encode()', f'{ind}b += _ZEROS[-len(b) & 3]',
                           f'{ind}b += _U32({v}.__len__() + 1)', f'{ind}b += {v}',
                           f"{ind}b += b'\\x00'"]
        elif not is_seq:
            raise _Unsupported(kind)
        elif base in _FORMATS:
            f = _FORMATS[base]
            size = struct.calcsize(f)
            code = ARRAY_CODES.get(base)                # the array.array rclpy may give
            self.lines.append(f'{ind}_sequence(b, {v}, {f!r}, {size}, {code!r})')
        elif base.startswith('string'):
            self.lines.append(f'{ind}_count(b, len({v}))')
            self.lines.append(f'{ind}for s in {v}:')
            self.lines.append(f'{ind}    _string(b, s)')
        elif '/' in base:
            m = f'm{len(self.lines)}'    # a name per loop: a nested loop must not rebind it
            self.lines.append(f'{ind}_count(b, len({v}))')
            self.lines.append(f'{ind}for {m} in {v}:')
            self.message(_class_of(base), m, ind + '    ')
            self.flush(ind + '    ')
        else:
            raise _Unsupported(kind)


def _count(b: bytearray, n: int) -> None:
    b += _ZEROS[-len(b) & 3]          # the payload starts at 4: its offset mod 4 is len(b)'s
    b += _U32(n)


def _string(b: bytearray, s: str) -> None:
    data = s.encode()
    _count(b, len(data) + 1)
    b += data
    b += b'\x00'


def _sequence(b: bytearray, v: Any, fmt: str, size: int, code: str | None) -> None:
    n = len(v)
    _count(b, n)
    if n:
        b += _ZEROS[-(len(b) - 4) % size]
        if type(v) is array.array and v.typecode == code:
            b += v.tobytes()
        else:
            b += struct.pack(f'<{n}{fmt}', *v)


def ends_padded(cls: type) -> bool:
    """Whether a message of ``cls`` is cut at its true end and padded to 4 bytes (the pad count
    in the options byte), as ``Recorder._cdr`` does unless its last field is a number, a string
    or a sequence of numbers narrower than 8 bytes or of strings."""
    kind = list(fields_of(cls).values())[-1]
    base, n, is_seq = element_of(kind)
    narrow = base.startswith('string') or (base in _FORMATS and base not in _WIDE)
    if is_seq:
        return not narrow
    return n is not None or not (narrow or base in _WIDE)


@functools.cache
def encoder(cls: Any) -> Encoder | None:
    """The CDR encoder of message class ``cls`` (bytes with the encapsulation header), or None
    when a field type is not handled (module docstring)."""
    gen = _Gen()
    try:
        gen.message(cls, 'msg', '    ')
    except (_Unsupported, ImportError, AttributeError, ValueError):
        return None
    gen.flush('    ')
    pad = ends_padded(cls)
    tail = ['    p = -(len(b) - 4) % 4', '    if p:', '        b += bytes(p)',
            '        b[3] = p'] if pad else []
    src = '\n'.join(['def enc(msg):', '    b = bytearray(_HEADER)', *gen.lines, *tail,
                     '    return bytes(b)'])
    scope: dict[str, Any] = {'_HEADER': _HEADER, '_ZEROS': _ZEROS, '_U32': _U32,
                             '_string': _string, '_count': _count, '_sequence': _sequence,
                             **gen.consts}
    exec(compile(src, f'<cdr {cls.__name__}>', 'exec'), scope)  # noqa: S102 (generated above)
    fn: Encoder = scope['enc']
    return fn


_CLOCK = struct.Struct('<4siI')


def clock_cdr(t_ns: int) -> bytes:
    """CDR of a rosgraph_msgs/Clock at ``t_ns`` (ns) without building the message: the
    encapsulation header, then builtin_interfaces/Time's int32 sec and uint32 nanosec (the
    recorder writes one per exchange; ``test_cdr`` checks it against rclpy)."""
    return _CLOCK.pack(b'\x00\x01\x00\x00', t_ns // 1_000_000_000, t_ns % 1_000_000_000)


TRIM_NEVER, TRIM_ALWAYS = '', '*'
"""What ``trim_rule`` says besides a field's name: never cut, always cut."""
_WIDE_SEQUENCES = ('sequence<double>', 'sequence<int64>', 'sequence<uint64>')
_NARROW = ('boolean', 'byte', 'char', 'octet', 'float', 'double', 'string', 'int8', 'uint8',
           'int16', 'uint16', 'int32', 'uint32', 'int64', 'uint64')


def force_readings_cdr(stamps_ns: list[int], forces_n: list[float], frame_id: str
                       ) -> list[bytes]:
    """CDR of load cell readings (geometry_msgs/WrenchStamped, as ``messages.force_reading``
    makes them: force.x, no torque), one per (stamp, force), without building the messages.

    The layout is fixed once the frame id is: the encapsulation header, the stamp's int32 sec
    and uint32 nanosec, the frame id (uint32 length with its NUL, the bytes, zeros up to the
    next multiple of 8 after the header), then six doubles. The rows are filled as columns of
    one array and cut, about a tenth of ``encoder``'s cost per message (a 1 kHz record of the
    campaign puts 700 thousand into the bag); ``test_cdr`` holds the bytes equal to it.

    Args:
        stamps_ns: the readings' stamps, ns (n).
        forces_n: their forces, N (n).
        frame_id: the load cell's frame.

    Returns:
        n CDR messages.
    """
    import numpy as np
    name = frame_id.encode('utf-8') + b'\x00'
    head = 12 + len(name)                        # sec, nanosec, length, then the name
    at = head + (-head % 8)                      # the doubles, counted after the header
    size = 4 + at + 48
    n = len(stamps_ns)
    rows = np.zeros((n, size), np.uint8)
    rows[:, :4] = np.frombuffer(b'\x00\x01\x00\x00', np.uint8)
    rows[:, 12:16] = np.frombuffer(_U32(len(name)), np.uint8)
    rows[:, 16:16 + len(name)] = np.frombuffer(name, np.uint8)
    stamps = np.asarray(stamps_ns, np.int64)
    sec, nanosec = np.divmod(stamps, 1_000_000_000)
    rows[:, 4:8] = sec.astype('<i4').view(np.uint8).reshape(n, 4)
    rows[:, 8:12] = nanosec.astype('<u4').view(np.uint8).reshape(n, 4)
    rows[:, 4 + at:12 + at] = np.asarray(forces_n, '<f8').view(np.uint8).reshape(n, 8)
    flat = rows.tobytes()
    return [flat[i:i + size] for i in range(0, n * size, size)]



def trim_rule(cls: type) -> str:
    """When a message of ``cls`` needs cutting (the recorder cuts the padding rclpy leaves
    after a message: ``nodes.recorder``): never (its last field is a number, a string or a
    sequence of narrow numbers), when its last field, a sequence of 8-byte numbers, is empty
    (that field's name), or always (measured)."""
    name, kind = list(fields_of(cls).items())[-1]
    if kind in _WIDE_SEQUENCES:
        return name
    if kind in _NARROW or kind.startswith('string') or (
            kind.startswith('sequence<') and kind[9:-1] in _NARROW[:-2]):
        return TRIM_NEVER
    return TRIM_ALWAYS
