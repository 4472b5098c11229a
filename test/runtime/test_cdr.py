"""The struct-built CDR of ``runtime.cdr`` against rclpy's and rosbags' own (de)serialisation."""

from __future__ import annotations

import random
import struct

import pytest
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseWithCovariance, WrenchStamped
from rclpy.serialization import deserialize_message, serialize_message
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import FluidPressure, JointState
from std_msgs.msg import Header, String

from pam_bench.bags.types import bench_typestore
from pam_bench.config import topics
from pam_bench.runtime.cdr import encoder, ends_padded, force_readings_cdr
from pam_bench.runtime.messages import (
    ForceSamples,
    force_reading,
    message_class,
    stamp_of_msg,
    time_of,
)

STORE = bench_typestore()
RECORDED = sorted({spec.partition(':')[2] for spec in
                   [t.spec for t in topics.TOPICS] + list(topics.EVENT_TOPICS)}
                  | {'pam_bench_interfaces/msg/DriveLaw', 'pam_bench_interfaces/msg/StepAck',
                     'pam_bench_interfaces/msg/TorqueSetpoint'})
_INTS = {'int8': 7, 'uint8': 8, 'int16': 15, 'uint16': 16, 'int32': 31, 'uint32': 32,
         'int64': 63, 'uint64': 64, 'octet': 8}


def _value(kind: str, rng: random.Random) -> object:
    """A random value of a field type string, as rclpy takes it."""
    if kind.startswith('sequence<'):
        base = kind[9:-1].split(',')[0]
        return [_value(base, rng) for _ in range(rng.randint(0, 3))]
    if kind.endswith(']'):
        base, _, n = kind[:-1].partition('[')
        return [_value(base, rng) for _ in range(int(n))]
    if kind == 'boolean':
        return rng.random() < 0.5
    if kind in ('float', 'double'):
        return struct.unpack('f', struct.pack('f', rng.uniform(-1e3, 1e3)))[0]
    if kind in _INTS:
        bits = _INTS[kind]
        lo = 0 if kind.startswith('u') or kind == 'octet' else -(2 ** (bits - 1))
        return rng.randint(lo, lo + 2 ** bits - 1) if kind != 'octet' else bytes([rng.randint(
            0, 255)])
    if kind.startswith('string'):
        return ''.join(rng.choice('abcdefgh_') for _ in range(rng.randint(0, 7)))
    return _fill(message_class(kind.replace('/', '/msg/')), rng)


def _fill(cls: type, rng: random.Random) -> object:
    msg = cls()
    for field, kind in cls.get_fields_and_field_types().items():
        setattr(msg, field, _value(kind, rng))
    return msg


@pytest.mark.parametrize('msgtype', RECORDED)
@pytest.mark.parametrize('seed', range(6))
def test_round_trips_through_rclpy_and_rosbags(msgtype: str, seed: int) -> None:
    """Every recorded type with random values, empty and full sequences and strings of every
    length mod 4: rclpy and the bag's reader read back what went in, and the bytes are
    rosbags' own serialisation of it (exact, zero padding)."""
    cls = message_class(msgtype)
    enc = encoder(cls)
    assert enc is not None, msgtype
    msg = _fill(cls, random.Random(seed))
    data = enc(msg)
    assert deserialize_message(data, cls) == msg
    decoded = STORE.deserialize_cdr(data, msgtype)
    again = bytes(STORE.serialize_cdr(decoded, msgtype))
    pad = -(len(again) - 4) % 4 if ends_padded(cls) else 0
    expected = again[:3] + bytes((pad,)) + again[4:] + bytes(pad)
    assert data == expected


@pytest.mark.parametrize(('cls', 'padded'), [
    (WrenchStamped, True), (JointState, True), (Clock, True), (Header, False), (String, False),
    (FluidPressure, False), (DiagnosticArray, True), (PoseWithCovariance, True)])
def test_end_padding_rule(cls: type, padded: bool) -> None:
    """Cut and padded at the end: a last field that is a nested message, an array or a sequence
    of 8-byte numbers or of messages; not: a number, a string (recorder's rule)."""
    assert ends_padded(cls) is padded


def test_known_bytes() -> None:
    """A Header with a 2-character frame: 4 + 8 + 4 + 3 bytes, no end padding."""
    msg = Header(stamp=Time(sec=1, nanosec=2), frame_id='ab')
    enc = encoder(Header)
    assert enc is not None
    assert enc(msg).hex() == '00010000' '01000000' '02000000' '03000000' '616200'
    assert enc(msg) == serialize_message(msg)


def test_nested_sequences_of_messages() -> None:
    """Diagnostics: a sequence of statuses each with a sequence of key-value strings."""
    msg = DiagnosticArray(status=[
        DiagnosticStatus(level=b'\x01', name='valve_1', message='commanded value rejected',
                         values=[KeyValue(key='value', value='nan'), KeyValue(key='k')]),
        DiagnosticStatus(level=b'\x00', name='m')])
    msg.header.stamp = time_of(3_000_000_007)
    enc = encoder(DiagnosticArray)
    assert enc is not None
    assert deserialize_message(enc(msg), DiagnosticArray) == msg


class _Wide:
    """A message class with a wide string, which the generator leaves to rclpy."""

    @staticmethod
    def get_fields_and_field_types() -> dict[str, str]:
        return {'value': 'double', 'text': 'wstring'}


def test_unsupported_type_falls_back() -> None:
    """A wide string is left to rclpy (no encoder)."""
    assert encoder(_Wide) is None


@pytest.mark.parametrize('t_ns', [0, 1, 999_999_999, 1_000_000_000, 86_400_123_456_789])
@pytest.mark.parametrize('force_n', [0.0, -3.25, 1999.9])
def test_force_reading_equals_the_constructed_message(t_ns: int, force_n: float) -> None:
    """The slot-filled reading is the message rosidl's constructors make, serialised alike."""
    ref = WrenchStamped()
    ref.header.stamp = time_of(t_ns)
    ref.header.frame_id = 'load_cell_2'
    ref.wrench.force.x = force_n
    msg = force_reading(t_ns, 'load_cell_2', force_n)
    assert msg == ref
    assert serialize_message(msg) == serialize_message(ref)
    enc = encoder(WrenchStamped)
    assert enc is not None and enc(msg) == serialize_message(ref)


@pytest.mark.parametrize('t_ns', [0, 1, 999_999_999, 1_000_000_000, 21_932_123_456_789,
                                  2**31 * 10**9 - 1])
def test_clock_cdr_is_rclpys_bytes(t_ns: int) -> None:
    """The recorder's Clock bytes without a message: rclpy's serialisation of the same Clock."""
    from pam_bench.runtime.cdr import clock_cdr
    assert clock_cdr(t_ns) == serialize_message(Clock(clock=time_of(t_ns)))


@pytest.mark.parametrize('frame_id', ['load_cell_1', 'load_cell_12', 'x', '', 'abcdefg',
                                      'ceLL-\u00e9'])
def test_force_readings_in_bulk_are_the_encoders_bytes(frame_id: str) -> None:
    """The bulk CDR of readings (every length of frame id modulo 8, a non-ASCII one) is, reading
    for reading, the generated encoder's bytes of ``force_reading``'s message."""
    rng = random.Random(len(frame_id))
    stamps = [0, 1, 999_999_999, 1_000_000_000, 2**31 * 10**9 - 1] + sorted(
        rng.randrange(0, 22_000 * 10**9) for _ in range(40))
    forces = [0.0, -0.0, float('nan'), 1999.9, -3.25] + [rng.uniform(-2e3, 2e3)
                                                            for _ in range(40)]
    enc = encoder(WrenchStamped)
    assert enc is not None
    expected = [enc(force_reading(t, frame_id, f)) for t, f in zip(stamps, forces, strict=True)]
    assert force_readings_cdr(stamps, forces, frame_id) == expected


def test_a_block_of_samples_reads_as_its_messages() -> None:
    """A ``ForceSamples`` block: stamped with its last reading, its points and messages those
    of the readings it stands for, its CDR theirs."""
    stamps, forces = [5_000_000, 6_000_000, 1_007_000_000], [1.5, -2.0, 3.25]
    block = ForceSamples(stamps, forces, 'load_cell_2')
    assert stamp_of_msg(block) == 1_007_000_000
    msgs = [force_reading(t, 'load_cell_2', f) for t, f in zip(stamps, forces, strict=True)]
    assert block.messages() == msgs
    assert block.points() == [((m.header.stamp.sec * 10**9 + m.header.stamp.nanosec) * 1e-9,
                               m.wrench.force.x) for m in msgs]
    enc = encoder(WrenchStamped)
    assert enc is not None and block.cdr() == [enc(m) for m in msgs]
