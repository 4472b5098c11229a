"""Protocol schedules of 004: the readings of each protocol (pure: no ROS, no wall clock).

A schedule is a list of ``Reading``: the set values to apply (valve voltage, loading-servo
mode and set value), the dwell after which the sensors are read (004: 3 s), and the labels of
the reading (series, step, direction). ``schedule_from_config`` builds it from an entry of
config/protocols.yaml; ``resume_index`` finds where an interrupted run starts again and
``with_approach`` takes the bench back along the path to that reading.
"""

from __future__ import annotations

import dataclasses
import enum
from collections.abc import Mapping
from typing import Any

import numpy as np

from pam_bench.models.loading_servo import LoadMode
from pam_bench.protocol.spec import check_protocol
from pam_bench.protocol.window import READING_WINDOW_S
from pam_bench.vocabulary.errors import ParameterError

__all__ = ['Direction', 'Reading', 'sweep', 'schedule_from_config', 'resume_index',
           'with_approach']


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
    pre_voltage_v: float | None = None   # hold this u during the dwell, then step to voltage_v
    record_s: float = 0.0                # after the step: record the force this long
    sample_period_s: float = 0.0         # of the record, s
    lead_s: float = 0.0                  # extra wait before the dwell (protocol change)
    recorded: bool = True                # False: an approach step (``with_approach``)
    window_s: float = 0.0                # average the samples of this last window (0: one)


def sweep(start: float, stop: float, step: float) -> np.ndarray:
    """start, start + step, ..., stop (inclusive), rounded to 1e-9 to stay exact on grids."""
    n = int(round((stop - start) / step))
    return np.round(start + step * np.arange(n + 1), 9)


def _load_mode(name: str) -> LoadMode:
    try:
        return LoadMode[name.upper()]
    except KeyError:
        raise ParameterError(f'unknown load mode {name!r}: use off, force or position') from None


def _isobaric_like(name: str, kind: str, cfg: Mapping[str, Any], get: Any, dwell: float
                   ) -> list[Reading]:
    out: list[Reading] = []
    if kind in ('isometric', 'isotonic'):
        held = get('x_m' if kind == 'isometric' else 'force_n')
        series = sweep(*[float(v) for v in held])
        swept = sweep(*[float(v) for v in get('voltage_v')])
        mode = LoadMode.POSITION if kind == 'isometric' else LoadMode.FORCE
    else:
        series = sweep(*[float(v) for v in get('voltage_v')])
        swept = sweep(*[float(v) for v in get('force_n')])
        mode = LoadMode.FORCE
    for s, held_value in enumerate(series):
        seq = [(Direction.UP, v) for v in swept] + [(Direction.DOWN, v) for v in swept[::-1]]
        for k, (d, v) in enumerate(seq):
            if kind == 'isobaric':
                u, load = float(held_value), float(v)
            else:
                u, load = float(v), float(held_value)
            out.append(Reading(name, s, k, d, float(held_value), float(v), u, mode, load, dwell))
    return out


def _step_response(name: str, get: Any, dwell: float) -> list[Reading]:
    out: list[Reading] = []
    positions = sweep(*[float(v) for v in get('x_m')])
    record, period = float(get('record_s')), float(get('sample_period_s'))
    for s, x in enumerate(positions):
        k = 0
        for direction, key in ((Direction.UP, 'up'), (Direction.DOWN, 'down')):
            spec = get(key)
            u0, du, n = float(spec['u0_v']), float(spec['step_v']), int(spec['n'])
            for i in range(1, n + 1):
                un = round(u0 + du * i, 9)
                out.append(Reading(name, s, k, direction, float(x), un, un, LoadMode.POSITION,
                                   float(x), dwell, pre_voltage_v=u0, record_s=record,
                                   sample_period_s=period))
                k += 1
    return out


def schedule_from_config(name: str, cfg: Mapping[str, Any],
                         table: Mapping[str, Any] | None = None
                         ) -> tuple[list[Reading], float]:
    """Readings and settle time (s) of a protocol described in config/protocols.yaml.

    Kinds: ``ramp`` (hold a load, ramp u through ``voltage_v`` breakpoints, read every
    ``reading_every_s``), ``isometric`` / ``isotonic`` (series of a held x or F, u swept up then
    down), ``isobaric`` (series of a held u, F swept up then down), ``step_response`` (per
    position: settle at u0, step to u0 + n du, record the force), ``campaign`` (the protocols
    named in ``protocols``, one after the other; needs ``table``). Every kind takes
    ``reading_window_s`` (default ``READING_WINDOW_S``): a reading averages the samples of that
    last window of its dwell (``protocol.window``).

    Raises:
        ParameterError: a missing or malformed key, named (``protocol.spec``).
    """
    def get(key: str) -> Any:
        if key not in cfg:
            raise ParameterError(f'protocol {name!r}: missing key {key!r}')
        return cfg[key]

    check_protocol(name, cfg)
    kind = get('kind')
    dwell = float(cfg.get('dwell_s', 3.0))
    settle = float(cfg.get('settle_s', dwell))
    window = float(cfg.get('reading_window_s', READING_WINDOW_S))
    if not 0.0 <= window <= dwell and kind != 'campaign':
        raise ParameterError(f'protocol {name!r}: reading_window_s {window} must be in '
                             f'[0, dwell_s = {dwell}]')

    def windowed(readings: list[Reading]) -> list[Reading]:
        return [dataclasses.replace(r, window_s=window) for r in readings]

    try:
        if kind == 'ramp':
            return windowed(_ramp(name, get)), settle
        if kind in ('isometric', 'isotonic', 'isobaric'):
            return windowed(_isobaric_like(name, kind, cfg, get, dwell)), settle
        if kind == 'step_response':
            return windowed(_step_response(name, get, dwell)), settle
        if kind == 'campaign':
            if table is None:
                raise ParameterError(f'protocol {name!r}: a campaign needs the protocol table')
            out: list[Reading] = []
            for i, sub in enumerate(get('protocols')):
                if sub not in table:
                    raise ParameterError(f'campaign {name!r}: unknown protocol {sub!r}')
                if table[sub].get('kind') == 'campaign':
                    raise ParameterError(f'campaign {name!r}: {sub!r} is a campaign itself')
                readings, sub_settle = schedule_from_config(sub, table[sub], table)
                if i > 0:
                    readings[0] = dataclasses.replace(readings[0], lead_s=sub_settle)
                else:
                    settle = sub_settle
                out.extend(readings)
            return out, settle
    except (TypeError, ValueError, KeyError) as exc:
        raise ParameterError(f'protocol {name!r}: malformed value ({exc})') from None
    raise ParameterError(f'protocol {name!r}: unknown kind {kind!r}')


def _ramp(name: str, get: Any) -> list[Reading]:
    out: list[Reading] = []
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
    return out


def resume_index(readings: list[Reading], done: set[tuple[str, int, int]]) -> int:
    """Index of the first reading not taken.

    Args:
        readings: the schedule.
        done: (protocol, series, step) of the readings already taken (from a bag).

    Returns:
        The index to restart at: 0 when nothing was taken, len(readings) when all was.
    """
    for i, r in enumerate(readings):
        if (r.protocol, r.series, r.step) not in done:
            return i
    return len(readings)


def with_approach(readings: list[Reading], index: int,
                  dwell_s: float | None = None) -> tuple[list[Reading], int]:
    """The schedule to resume at ``readings[index]`` in the middle of a series.

    The bench is taken along the protocol's own path up to ``index``: every reading of the
    series before it and of the one before that, in order, each held its own dwell (or
    ``dwell_s``) and not recorded
    (``recorded`` False: no point, no record; a ramp or a step reading holds its final
    voltage). The braid's friction is rate independent (Maxwell-slip, 004 section 2.1 and
    ``models.friction``): its state is set by the path's turning points, and the previous
    series, which sweeps the whole range, wipes out those before it. So the reading at
    ``index`` meets the muscle in the state the uninterrupted run left it in; and every move
    is one step of the protocol's own grid, which the loading servo follows as it did in the
    run (a jump across a series, to a turning point, can leave the drive at its torque limit
    and the force out of tolerance). Where a reading sits in a wide friction loop, the drive's
    transient decides where the muscle stops (README, "Protocols and scenes"), so the approach
    keeps the run's own dwells: it is the run again, unrecorded. The first series of a
    protocol starts as it did.

    Returns:
        The new schedule and the index to start it at (the first approach step).
    """
    if index <= 0 or index >= len(readings):
        return readings, index
    r = readings[index]
    first = index
    series = {r.series, r.series - 1}
    while first > 0 and readings[first - 1].protocol == r.protocol and \
            readings[first - 1].series in series:
        first -= 1
    if first == index:
        return readings, index
    approach = [dataclasses.replace(k, dwell_s=k.dwell_s if dwell_s is None else dwell_s,
                                    ramp_from_v=None, pre_voltage_v=None,
                                    record_s=0.0, sample_period_s=0.0, lead_s=0.0,
                                    recorded=False) for k in readings[first:index]]
    return readings[:index] + approach + readings[index:], index
