"""Message helpers of the bench nodes: stamps as integer nanoseconds, message classes by name,
acknowledgements between their plain form (``sim.lockstep.Ack``) and StepAck."""

from __future__ import annotations

import array
import contextlib
import functools
import importlib
import struct
from typing import Any

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Vector3, Wrench, WrenchStamped
from pam_bench_interfaces.msg import StepAck
from std_msgs.msg import Header

from pam_bench.sim.lockstep import Ack, StopRequest
from pam_bench.vocabulary.imports import import_without

__all__ = ['import_rosidl_lean', 'floats', 'ns_of', 'clock_ns', 'stamp_of_cdr', 'stamp_of_msg',
           'message_class', 'time_of', 'ack_message', 'ack_of', 'force_reading', 'ForceSamples']


GENERATOR = 'rosidl_generator_py.generate_py_impl'
"""The module of ROS's message code generator, which ``rosidl_generator_py`` imports."""


def import_rosidl_lean() -> None:
    """Import ``rosidl_generator_py`` without its code generator.

    Every message class loads its type support through ``rosidl_generator_py``, whose package
    also imports the generator (``generate_py_impl``: empy, lark and rosidl_parser, about 60 ms
    of every node process's start) only to offer ``generate_py``, which a running node never
    calls; where that import fails, the package carries on without it (its own fallback). Here
    it fails: the generator's module is held out while the package is imported, and put back at
    once, so an explicit import of the generator still works. Nothing when the package is
    already imported or not installed (docs/long_runs.md, "ROS's message generator at every
    start").
    """
    with contextlib.suppress(ImportError):
        import_without('rosidl_generator_py', GENERATOR)


def floats(values: Any) -> array.array:
    """A float64[] field's value as rosidl takes it without checking every element
    (``array('d')``: its setter's fast path; a list of 600 sub-step samples costs the element
    checks otherwise)."""
    if isinstance(values, array.array):
        return values
    return array.array('d', values)


def ns_of(stamp: Time) -> int:
    """A ROS time stamp as integer nanoseconds."""
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def stamp_of_cdr(data: bytes) -> int:
    """Stamp (ns) of a CDR-serialised message that starts with a Header or a Time."""
    order = '<' if data[1] == 1 else '>'
    sec, nsec = struct.unpack_from(order + 'iI', data, 4)
    return sec * 1_000_000_000 + nsec


def message_class(msgtype: str) -> type:
    """The rclpy message class of 'package/msg/Type'."""
    pkg, kind, name = msgtype.split('/')
    return getattr(importlib.import_module(f'{pkg}.{kind}'), name)


def stamp_of_msg(msg: Any) -> int:
    """Stamp (ns) of a message object with a Header (or of a Clock).

    rosidl's messages keep their fields in slots named ``_field`` behind properties; the
    composed lock-step reads a stamp from every message it delivers (about 30 per servo
    exchange), so the slots are read directly, and the properties where an object has none.
    """
    try:
        stamp = msg._header._stamp
    except AttributeError:
        try:
            stamp = msg.header.stamp
        except AttributeError:
            stamp = msg.clock
    try:
        return stamp._sec * 1_000_000_000 + stamp._nanosec
    except AttributeError:
        return stamp.sec * 1_000_000_000 + stamp.nanosec


def clock_ns(msg: Any) -> int:
    """Time (ns) of a Clock message object, from rosidl's slots where it has them (every
    participant reads one per exchange)."""
    try:
        c = msg._clock
        return c._sec * 1_000_000_000 + c._nanosec
    except AttributeError:
        return ns_of(msg.clock)


def ack_message(ack: Ack) -> StepAck:
    """The StepAck message of an acknowledgement."""
    msg = StepAck(node=ack.node, max_next_step=ack.max_next_step_s)
    if ack.stop is not None:
        msg.stop, msg.exit_code, msg.reason = True, ack.stop.exit_code, ack.stop.reason
    msg.header.stamp = time_of(ack.t_ns)
    return msg


def ack_of(msg: Any) -> Ack:
    """The acknowledgement a StepAck message (or, in process, the Ack itself) carries."""
    if isinstance(msg, Ack):
        return msg
    stop = StopRequest(int(msg.exit_code), msg.reason) if msg.stop else None
    return Ack(ns_of(msg.header.stamp), msg.node, float(msg.max_next_step), stop)


@functools.lru_cache(maxsize=16)
def time_of(ns: int) -> Time:
    """Integer nanoseconds as a ROS time stamp. The nodes of one process that stamp the same
    tick share one object (it is never changed after it is made)."""
    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


_NO_TORQUE = Vector3()
_SLOTTED = all(f'_{name}' in cls.__slots__ for cls, names in (
    (Time, ('sec', 'nanosec')), (Header, ('stamp', 'frame_id')), (Vector3, ('x', 'y', 'z')),
    (Wrench, ('force', 'torque')), (WrenchStamped, ('header', 'wrench')))
    for name in (*names, 'check_fields'))


def force_reading(t_ns: int, frame_id: str, force_n: float) -> WrenchStamped:
    """A load cell reading: WrenchStamped stamped ``t_ns`` (ns) with force.x = ``force_n`` (N)
    and no torque (all receivers share one zero torque vector and must not change it).

    A load cell in a 1 kHz record publishes one per sample. rosidl's keyword constructors
    check every field of the five nested messages (about 7 us with the stamp); this one fills
    their value slots directly (about 0.8 us), the way the constructors leave them, when the
    generated classes have those slots.
    """
    if not _SLOTTED:
        msg = WrenchStamped()
        msg.header.stamp = time_of(t_ns)
        msg.header.frame_id = frame_id
        msg.wrench.force.x = force_n
        return msg
    new = object.__new__
    t = new(Time)
    t._sec, t._nanosec = divmod(t_ns, 1_000_000_000)
    h = new(Header)
    h._stamp, h._frame_id = t, frame_id
    f = new(Vector3)
    f._x, f._y, f._z = float(force_n), 0.0, 0.0
    w = new(Wrench)
    w._force, w._torque = f, _NO_TORQUE
    msg = new(WrenchStamped)
    msg._header, msg._wrench = h, w
    t._check_fields = h._check_fields = f._check_fields = w._check_fields = False
    msg._check_fields = False
    return msg


class ForceSamples:
    """Consecutive load cell readings of one exchange, carried in process as one object.

    In a composed run's 1 kHz record a load cell publishes every sample of the exchange, a
    thousand WrenchStamped objects that only the sequencer and the recorder read. Where every
    in-process subscription of its topic takes them (``runtime.intra``, ``InputSpec.blocks``)
    it publishes the samples before the exchange's last one as one ``ForceSamples``, stamped
    (``header``) with its own last sample so that the lock-step buffers it among the messages
    of that exchange; the exchange's last sample, on the grid, stays a message. A reader takes
    the floats (``points``) or the CDR of every reading (``cdr``, what the recorder writes);
    ``messages`` rebuilds the WrenchStamped objects (for a subscriber outside the process).
    """

    __slots__ = ('header', 'stamps_ns', 'forces_n')

    def __init__(self, stamps_ns: list[int], forces_n: list[float], frame_id: str) -> None:
        """``stamps_ns`` (ns, increasing) and ``forces_n`` (N) of n >= 1 readings of the
        load cell ``frame_id``."""
        self.stamps_ns, self.forces_n = stamps_ns, forces_n
        self.header = Header(stamp=time_of(stamps_ns[-1]), frame_id=frame_id)

    def points(self) -> list[tuple[float, float]]:
        """(time s, force N) of each reading, as a reader of the messages computes them."""
        return [(t * 1e-9, f) for t, f in zip(self.stamps_ns, self.forces_n, strict=True)]

    def cdr(self) -> list[bytes]:
        """The CDR of each reading's WrenchStamped (``cdr.force_readings_cdr``)."""
        from pam_bench.runtime.cdr import force_readings_cdr
        return force_readings_cdr(self.stamps_ns, self.forces_n, self.header.frame_id)

    def messages(self) -> list[WrenchStamped]:
        """Each reading as the WrenchStamped a load cell publishes (``force_reading``)."""
        fid = self.header.frame_id
        return [force_reading(t, fid, f) for t, f in zip(self.stamps_ns, self.forces_n,
                                                          strict=True)]
