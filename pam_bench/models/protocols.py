"""Protocol schedules and the sequencer state machine (pure: no ROS, no wall clock).

A schedule is a list of ``Reading``: the set values to apply (valve voltage, loading-servo
mode and set value), the dwell after which the sensors are read (004: 3 s), and the labels of
the reading (series, step, direction). The ``Sequencer`` is ticked with the sim time and the
latest measurements and returns the commands to send and, at the end of each dwell, the point.
"""

from __future__ import annotations

import dataclasses
import enum
from collections.abc import Mapping
from typing import Any

import numpy as np

from pam_bench.models.errors import ParameterError
from pam_bench.models.loading_servo import LoadMode

__all__ = ['Phase', 'Direction', 'Reading', 'Measurement', 'Point', 'Commands', 'Sequencer',
           'sweep', 'schedule_from_config']


class Phase(enum.Enum):
    """Phase of the sequencer."""

    IDLE = 'idle'
    SETTLE = 'settle'
    DWELL = 'dwell'
    DONE = 'done'
    ABORTED = 'aborted'
    CANCELLED = 'cancelled'


class Direction(enum.IntEnum):
    """Sweep direction (values match CharacteristicPoint.DIRECTION_*)."""

    UP = 0
    DOWN = 1


@dataclasses.dataclass(frozen=True)
class Reading:
    """One scheduled reading: set values (SI) and labels."""

    protocol: str
    series: int
    step: int
    direction: Direction
    series_value: float
    set_value: float
    voltage_v: float
    load_mode: LoadMode
    load_value: float
    dwell_s: float
    ramp_from_v: float | None = None     # ramp u linearly from this value over the dwell


@dataclasses.dataclass(frozen=True)
class Measurement:
    """Latest measured values: force N, contraction m, gauge pressure Pa."""

    force_n: float
    contraction_m: float
    pressure_pa: float


@dataclasses.dataclass(frozen=True)
class Point:
    """A reading taken: the schedule entry, the sim time (s) and the measurement."""

    reading: Reading
    t_s: float
    voltage_v: float
    measurement: Measurement


@dataclasses.dataclass(frozen=True)
class Commands:
    """What to send now, and the point taken at this tick (if any)."""

    voltage_v: float
    load_mode: LoadMode
    load_value: float
    point: Point | None


def sweep(start: float, stop: float, step: float) -> np.ndarray:
    """start, start + step, ..., stop (inclusive), rounded to 1e-9 to stay exact on grids."""
    n = int(round((stop - start) / step))
    return np.round(start + step * np.arange(n + 1), 9)


def _load_mode(name: str) -> LoadMode:
    try:
        return LoadMode[name.upper()]
    except KeyError:
        raise ParameterError(f'unknown load mode {name!r}: use off, force or position') from None


def schedule_from_config(name: str, cfg: Mapping[str, Any]) -> tuple[list[Reading], float]:
    """Readings and settle time (s) of a protocol described in config/protocols.yaml.

    Kinds: ``ramp`` (hold a load, ramp u through ``voltage_v`` breakpoints, read every
    ``reading_every_s``), ``isometric`` / ``isotonic`` (series of a held x or F, u swept up then
    down), ``isobaric`` (series of a held u, F swept up then down).

    Raises:
        ParameterError: a missing or malformed key, named.
    """
    def get(key: str) -> Any:
        if key not in cfg:
            raise ParameterError(f'protocol {name!r}: missing key {key!r}')
        return cfg[key]

    kind = get('kind')
    dwell = float(cfg.get('dwell_s', 3.0))
    settle = float(cfg.get('settle_s', dwell))
    out: list[Reading] = []
    if kind == 'ramp':
        mode = _load_mode(get('load_mode'))
        load = float(get('load_value'))
        pts = [float(v) for v in get('voltage_v')]
        every = float(get('reading_every_s'))
        rate = float(get('ramp_rate_v_per_s'))
        step = 0
        for a, b in zip(pts[:-1], pts[1:], strict=True):
            n = max(1, int(round(abs(b - a) / rate / every)))
            d = Direction.UP if b >= a else Direction.DOWN
            for i in range(1, n + 1):
                u0, u1 = a + (b - a) * (i - 1) / n, a + (b - a) * i / n
                out.append(Reading(name, 0, step, d, load, u1, u1, mode, load, every,
                                   ramp_from_v=u0))
                step += 1
        return out, settle
    if kind in ('isometric', 'isotonic'):
        held = get('x_m' if kind == 'isometric' else 'force_n')
        series = sweep(*[float(v) for v in held])
        volts = sweep(*[float(v) for v in get('voltage_v')])
        mode = LoadMode.POSITION if kind == 'isometric' else LoadMode.FORCE
        for s, val in enumerate(series):
            seq = [(Direction.UP, u) for u in volts] + [(Direction.DOWN, u) for u in volts[::-1]]
            for k, (d, u) in enumerate(seq):
                out.append(Reading(name, s, k, d, float(val), float(u), float(u), mode,
                                   float(val), dwell))
        return out, settle
    if kind == 'isobaric':
        volts = sweep(*[float(v) for v in get('voltage_v')])
        forces = sweep(*[float(v) for v in get('force_n')])
        for s, u in enumerate(volts):
            seq = [(Direction.UP, f) for f in forces] + [(Direction.DOWN, f)
                                                         for f in forces[::-1]]
            for k, (d, f) in enumerate(seq):
                out.append(Reading(name, s, k, d, float(u), float(f), float(u), LoadMode.FORCE,
                                   float(f), dwell))
        return out, settle
    raise ParameterError(f'protocol {name!r}: unknown kind {kind!r}')


class Sequencer:
    """State machine over a schedule. ``tick`` is called at every sim-time step."""

    def __init__(self, name: str, readings: list[Reading], settle_s: float) -> None:
        if not readings:
            raise ParameterError(f'protocol {name!r} has no readings')
        self.name = name
        self.readings = readings
        self.settle_s = settle_s
        self.phase = Phase.IDLE
        self.index = 0
        self.t_phase = 0.0
        self.t_start = 0.0
        self.reason = ''
        self.points_done = 0

    @property
    def total_s(self) -> float:
        """Scheduled sim time of the whole run, s."""
        return self.settle_s + sum(r.dwell_s for r in self.readings)

    def remaining_s(self, t_s: float) -> float:
        """Scheduled sim time still to run, s."""
        if self.phase in (Phase.DONE, Phase.ABORTED, Phase.CANCELLED, Phase.IDLE):
            return 0.0 if self.phase != Phase.IDLE else self.total_s
        return max(self.total_s - (t_s - self.t_start), 0.0)

    def start(self, t_s: float) -> None:
        """Begin with the settle phase at the first reading's set values."""
        self.phase, self.t_phase, self.t_start, self.index = Phase.SETTLE, t_s, t_s, 0

    def stop(self, phase: Phase, reason: str) -> None:
        """End early (ABORTED or CANCELLED) with a reason."""
        if self.phase not in (Phase.DONE, Phase.ABORTED, Phase.CANCELLED):
            self.phase, self.reason = phase, reason

    def _voltage(self, r: Reading, t_s: float) -> float:
        if r.ramp_from_v is None or self.phase != Phase.DWELL:
            return r.voltage_v
        a = min(max((t_s - self.t_phase) / r.dwell_s, 0.0), 1.0)
        return r.ramp_from_v + (r.voltage_v - r.ramp_from_v) * a

    def tick(self, t_s: float, meas: Measurement) -> Commands:
        """Advance to ``t_s`` given the latest measurement; return what to command."""
        eps = 1e-9
        point = None
        if self.phase == Phase.SETTLE and t_s - self.t_phase >= self.settle_s - eps:
            self.phase, self.t_phase = Phase.DWELL, t_s
        elif self.phase == Phase.DWELL:
            r = self.readings[self.index]
            if t_s - self.t_phase >= r.dwell_s - eps:
                point = Point(r, t_s, r.voltage_v, meas)
                self.points_done += 1
                self.index += 1
                self.t_phase = t_s
                if self.index >= len(self.readings):
                    self.phase = Phase.DONE
        if self.phase in (Phase.SETTLE, Phase.DWELL):
            r = self.readings[self.index]
            first = self.readings[0]
            if self.phase == Phase.SETTLE:
                u0 = first.ramp_from_v if first.ramp_from_v is not None else first.voltage_v
                return Commands(u0, first.load_mode, first.load_value, point)
            return Commands(self._voltage(r, t_s), r.load_mode, r.load_value, point)
        # idle, done, aborted, cancelled: vent the valve, hold the last load
        last = self.readings[min(self.index, len(self.readings) - 1)]
        if self.phase == Phase.DONE:
            return Commands(0.0, last.load_mode, last.load_value, point)
        return Commands(0.0, LoadMode.OFF, 0.0, point)
