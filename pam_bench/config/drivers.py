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

__all__ = ['Expect', 'Seen', 'Verdict', 'contract', 'judge', 'COMMANDS']


@dataclasses.dataclass(frozen=True)
class Expect:
    """One measured topic of the contract.

    Attributes:
        topic: absolute name.
        msgtype: 'package/msg/Type'.
        field: where the value is and its unit (for the table).
        low, high: plausible value range (unit of ``field``).
        min_rate_hz: slowest acceptable mean rate (Hz).
        min_step: smallest plausible nonzero change between distinct values (a smaller one
            means a unit 1000 times too large, e.g. kN for N); 0: no check.
        max_age_s: largest acceptable receive time - header stamp (s), median over messages.
    """

    topic: str
    msgtype: str
    field: str
    low: float
    high: float
    min_rate_hz: float
    min_step: float = 0.0
    max_age_s: float = 0.05


COMMANDS = {'sequencer': [topics.absolute(topics.valve_command(1)),
                          topics.absolute(topics.LOAD_COMMAND)],
            'torque_servo': [topics.absolute(topics.valve_command(1)),
                             topics.absolute(topics.valve_command(2))]}
"""Command topics a driver must subscribe to, per controller."""


def _pressure(ch: int) -> Expect:
    return Expect(topics.absolute(topics.valve_pressure(ch)), 'sensor_msgs/msg/FluidPressure',
                  'fluid_pressure, Pa absolute', 0.5 * ATMOSPHERE_PA, ATMOSPHERE_PA + 1.2e6,
                  100.0)


def _force(ch: int) -> Expect:
    return Expect(topics.absolute(topics.load_cell_force(ch)), 'geometry_msgs/msg/WrenchStamped',
                  'wrench.force.x, N', -LOAD_CELL_RANGE_N, LOAD_CELL_RANGE_N, 900.0,
                  min_step=1e-3)


ENCODER = Expect(topics.absolute(topics.ENCODER), 'sensor_msgs/msg/JointState',
                 "position['pulley'], rad", -3.2, 3.2, 900.0)


def contract(controllers: Sequence[str]) -> list[Expect]:
    """The measured topics the given controllers ('sequencer', 'torque_servo') read."""
    out: dict[str, Expect] = {}
    if 'sequencer' in controllers:
        for e in (_force(1), ENCODER, _pressure(1)):
            out[e.topic] = e
    if 'torque_servo' in controllers:
        for e in (_force(1), _force(2), ENCODER):
            out[e.topic] = e
    return list(out.values())


@dataclasses.dataclass
class Seen:
    """What the probe saw of one topic over its window.

    Attributes:
        types: the types its publishers announce.
        reliable: one flag per publisher (True: reliable).
        recv_ns, stamp_ns: receive time and header stamp per message, shape (n,).
        values: the value per message (unit of ``Expect.field``), shape (n,).
        window_s: how long the probe listened (s).
    """

    types: list[str]
    reliable: list[bool]
    recv_ns: list[int]
    stamp_ns: list[int]
    values: list[float]
    window_s: float


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
    expected = f'{e.msgtype.split("/")[-1]} {e.field} >= {e.min_rate_hz:g} Hz'

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
    seen += f', {v.min():.4g}..{v.max():.4g}'
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
    if not np.all(np.isfinite(v)):
        return fail(seen, 'non-finite values')
    if v.min() < e.low or v.max() > e.high:
        hint = ''
        if 'absolute' in e.field and v.max() < e.low:
            hint = ' (gauge pressure? the contract is absolute)'
        return fail(seen, f'values outside {e.low:.4g}..{e.high:.4g}{hint}')
    distinct = np.unique(v)
    if e.min_step > 0 and distinct.size > 1:
        step = float(np.min(np.diff(distinct)))
        if step < e.min_step and float(np.ptp(v)) < 1000 * e.min_step * 10:
            return fail(seen, f'steps of {step:.2g} are below {e.min_step:g}: wrong unit '
                        '(kN for N?)')
    note = '' if all(s.reliable) else 'best effort: a recorder may lose messages'
    return Verdict(e.topic, expected, seen, True, note)
