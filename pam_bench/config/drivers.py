"""The driver contract: what a lab's device drivers must publish for the sequencer, the servo
and the recorder to run on them, and the rules ``pam-bench check-drivers`` judges them by.

Each measured topic has a type, a field and unit, a plausible value range, a minimum rate and
a freshness bound on its header stamp (docs/drivers.md says why each). The checks work on what
a probe saw: the publishers (type, reliability), and per message the receive time, the header
stamp and the value. No rclpy here: the probe that collects is ``nodes.driver_probe``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from pam_bench.config import topics
from pam_bench.models.constants import ATMOSPHERE_PA, LOAD_CELL_RANGE_N

__all__ = ['Expect', 'Seen', 'Verdict', 'contract', 'contract_table', 'judge', 'COMMANDS',
           'ENCODER', 'DRIVE']


@dataclasses.dataclass(frozen=True)
class Expect:
    """One measured topic of the contract: a row of docs/drivers.md's table and the rules the
    checker applies to it (``contract_table`` renders the rows the document holds, and a
    test keeps the two equal).

    Attributes:
        topic: absolute name.
        msgtype: 'package/msg/Type'.
        field: where the value is and its unit (for the table).
        low, high: plausible value range (unit of ``field``).
        min_rate_hz: slowest acceptable mean rate (Hz).
        min_step: smallest plausible nonzero change between distinct values; values that
            change by less and whose whole spread is under 10 of it (a sensor's noise alone
            spans more) mean a unit 1000 times too large, e.g. kN for N; 0: no check. A fine
            converter alone (a 24-bit amplifier's 0.2 mN) does not fail it: its noise spreads.
        max_age_s: largest acceptable receive time - header stamp (s), median over messages.
        frame_id: the ``header.frame_id`` every message carries ('': any).
        joint: the joint whose position is the value (JointState topics).
        read_by: who reads it (for the table).
        note: what else the table says of it.
    """

    topic: str
    msgtype: str
    field: str
    low: float
    high: float
    min_rate_hz: float
    min_step: float = 0.0
    max_age_s: float = 0.05
    frame_id: str = ''
    joint: str = ''
    read_by: str = ''
    note: str = ''


COMMANDS = {'sequencer': [topics.absolute(topics.valve_command(1)),
                          topics.absolute(topics.LOAD_COMMAND)],
            'torque_servo': [topics.absolute(topics.valve_command(1)),
                             topics.absolute(topics.valve_command(2))]}
"""Command topics a driver must subscribe to, per controller."""


def _pressure(ch: int) -> Expect:
    return Expect(topics.absolute(topics.valve_pressure(ch)), 'sensor_msgs/msg/FluidPressure',
                  '`fluid_pressure`, Pa **absolute**', 0.5 * ATMOSPHERE_PA,
                  ATMOSPHERE_PA + 1.2e6, 100.0, frame_id=f'valve_{ch}', read_by='sequencer')


def _force(ch: int) -> Expect:
    return Expect(topics.absolute(topics.load_cell_force(ch)), 'geometry_msgs/msg/WrenchStamped',
                  '`wrench.force.x`, N, tension positive', -LOAD_CELL_RANGE_N,
                  LOAD_CELL_RANGE_N, 900.0, min_step=1e-3, frame_id=f'load_cell_{ch}',
                  read_by='sequencer (N = 1), servo (N = 1, 2)')


ENCODER = Expect(topics.absolute(topics.ENCODER), 'sensor_msgs/msg/JointState',
                 '`position` of joint `pulley`, rad; `velocity` rad/s', -3.2, 3.2, 900.0,
                 joint=topics.PULLEY_JOINT, read_by='sequencer, servo')
DRIVE = Expect(topics.absolute(topics.LOAD_STATE), 'sensor_msgs/msg/JointState',
               '`position` of joint `motor`, rad; `velocity` rad/s; `effort` N m', -1e5, 1e5,
               100.0, joint=topics.MOTOR_JOINT, read_by='sequencer (its age: input `drive`), '
               'recorder', note='only while the drive follows its set value (none in fault or '
               'quick stop)')


def contract(controllers: Sequence[str]) -> list[Expect]:
    """The measured topics the given controllers ('sequencer', 'torque_servo') read."""
    out: dict[str, Expect] = {}
    if 'sequencer' in controllers:
        for e in (_force(1), ENCODER, _pressure(1), DRIVE):
            out[e.topic] = e
    if 'torque_servo' in controllers:
        for e in (_force(1), _force(2), ENCODER):
            out[e.topic] = e
    return list(out.values())


def contract_table() -> str:
    """The contract's measured topics as docs/drivers.md shows them (markdown): one row per
    topic kind, channel ``N``, from the very rows the checker judges by."""
    rows = ['| topic | type | field, unit | `frame_id` | rate | read by |',
            '|---|---|---|---|---|---|']
    for e in (_force(1), ENCODER, _pressure(1), DRIVE):
        name = e.topic.lstrip('/').replace('_1/', '_N/')
        frame = f'`{e.frame_id.replace("_1", "_N")}`' if e.frame_id else 'any'
        field = e.field + (f'; {e.note}' if e.note else '')
        rows.append(f'| `{name}` | `{e.msgtype}` | {field} | {frame} | '
                    f'>= {e.min_rate_hz:g} Hz | {e.read_by} |')
    return '\n'.join(rows)


@dataclasses.dataclass
class Seen:
    """What the probe saw of one topic over its window.

    Attributes:
        types: the types its publishers announce.
        reliable: one flag per publisher (True: reliable).
        recv_ns, stamp_ns: receive time and header stamp per message, shape (n,).
        values: the value per message (unit of ``Expect.field``), shape (n,); NaN where the
            message lacks it (no such joint).
        window_s: how long the probe listened (s).
        frame_ids: every ``header.frame_id`` seen.
    """

    types: list[str]
    reliable: list[bool]
    recv_ns: list[int]
    stamp_ns: list[int]
    values: list[float]
    window_s: float
    frame_ids: set[str] = dataclasses.field(default_factory=set)


@dataclasses.dataclass(frozen=True)
class Verdict:
    """One row of the table: topic, expected, seen, pass/fail, reason."""

    topic: str
    expected: str
    seen: str
    ok: bool
    reason: str


def judge(e: Expect, s: Seen) -> Verdict:
    """Judge one topic; the first failed rule gives the reason."""
    plain = e.field.split(';')[0].replace('`', '').replace('*', '')
    expected = f'{e.msgtype.split("/")[-1]} {plain} >= {e.min_rate_hz:g} Hz'

    def fail(seen: str, reason: str) -> Verdict:
        return Verdict(e.topic, expected, seen, False, reason)

    if not s.types:
        return fail('no publisher', 'topic not published')
    if e.msgtype not in s.types:
        return fail(', '.join(s.types), f'type {s.types[0]}, expected {e.msgtype}')
    n = len(s.recv_ns)
    if n < 2:
        return fail(f'{n} message(s)', f'{n} message(s) in {s.window_s:.1f} s')
    span = (s.recv_ns[-1] - s.recv_ns[0]) * 1e-9       # the first messages after the match
    rate = (n - 1) / span if span > 0 else float('inf')
    seen = f'{rate:.0f} Hz'
    if span < 0.5 * s.window_s:
        return fail(seen, f'messages during {span:.2f} s of a {s.window_s:.1f} s window')
    v = np.asarray(s.values, dtype=float)
    bad = int(np.sum(~np.isfinite(v)))
    fin = v[np.isfinite(v)]
    seen += f', {fin.min():.4g}..{fin.max():.4g}' if fin.size else ', no finite value'
    if bad:
        seen += f' ({bad} not finite)'
    if rate < e.min_rate_hz:
        return fail(seen, f'rate {rate:.0f} Hz below {e.min_rate_hz:g} Hz')
    stamps = np.asarray(s.stamp_ns, dtype=np.int64)
    if np.any(np.diff(stamps) <= 0):
        repeats = int(np.sum(np.diff(stamps) <= 0))
        return fail(seen, f'header stamps not increasing ({repeats} of {n - 1} steps)')
    age = float(np.median((np.asarray(s.recv_ns, dtype=np.int64) - stamps) * 1e-9))
    seen += f', age {age * 1e3:.1f} ms'
    if not -0.005 <= age <= e.max_age_s:
        return fail(seen, f'stamp age {age * 1e3:.1f} ms outside -5..{e.max_age_s * 1e3:.0f} '
                    'ms (stamp from the sensor clock, synchronised with this host?)')
    if bad:
        where = f' (no joint {e.joint!r}?)' if e.joint and not fin.size else ''
        return fail(seen, f'{bad} of {n} values not finite{where}')
    if e.frame_id and s.frame_ids != {e.frame_id}:
        return fail(seen, f'header.frame_id {", ".join(sorted(repr(f) for f in s.frame_ids))}'
                    f', expected {e.frame_id!r}')
    if v.min() < e.low or v.max() > e.high:
        hint = ''
        if 'absolute' in e.field and v.max() < e.low:
            hint = ' (gauge pressure? the contract is absolute)'
        return fail(seen, f'values outside {e.low:.4g}..{e.high:.4g}{hint}')
    distinct = np.unique(v)
    if e.min_step > 0 and distinct.size > 1:
        step = float(np.min(np.diff(distinct)))
        if step < e.min_step and float(np.ptp(v)) < 10 * e.min_step:
            return fail(seen, f'steps of {step:.2g} are below {e.min_step:g}: wrong unit '
                        '(kN for N?)')
    note = '' if all(s.reliable) else 'best effort: a recorder may lose messages'
    return Verdict(e.topic, expected, seen, True, note)
