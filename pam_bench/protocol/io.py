"""What the sequencer takes in and hands out: measurements, points, step records, commands.

A ``Measurement`` is the latest force, contraction and pressure; a ``Point`` a reading taken;
a ``StepRecord`` the 1 kHz force after a valve step (filled by stamp in a ``RecordWindow``);
``Commands`` what the sequencer sends at a tick. Used by ``protocol.sequencer``, the node and
the twin.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from pam_bench.models.loading_servo import LoadMode
from pam_bench.protocol.schedules import Reading

__all__ = ['Measurement', 'Point', 'StepRecord', 'Commands', 'RecordWindow']


@dataclasses.dataclass(frozen=True)
class Measurement:
    """Latest measured values: force N, contraction m, gauge pressure Pa."""

    force_n: float
    contraction_m: float
    pressure_pa: float


@dataclasses.dataclass(frozen=True)
class Point:
    """A reading taken: the schedule entry, the sim time (s) and the measurement (force and
    contraction averaged over the reading's window, ``protocol.window``).

    Attributes:
        window_n: force samples averaged.
        outliers: (input, stamp s, value) of each sample of the window left out for being
            outside the input's band.
    """

    reading: Reading
    t_s: float
    voltage_v: float
    measurement: Measurement
    window_n: int = 1
    outliers: tuple[tuple[str, float, float], ...] = ()


@dataclasses.dataclass(frozen=True)
class StepRecord:
    """A step response: the reading taken at the end of its window and the force every
    ``reading.sample_period_s`` from the step on.

    Attributes:
        point: the reading at the end of the record window.
        t_step_s: sim time of the valve step, s.
        samples: force sample i belongs to t_step_s + i T, N; shape (record_s / T,).
    """

    point: Point
    t_step_s: float
    samples: tuple[float, ...]

    @property
    def reading(self) -> Reading:
        """The schedule entry of the step."""
        return self.point.reading


@dataclasses.dataclass(frozen=True)
class Commands:
    """What to send now, the point taken at this tick (if any), a step record completed at
    this tick (if any) and the pressure sample period to ask the valve for (s, 0: none)."""

    voltage_v: float
    load_mode: LoadMode
    load_value: float
    point: Point | None
    record: StepRecord | None = None
    sample_period_s: float = 0.0


@dataclasses.dataclass
class RecordWindow:
    """A step record being filled: force sample i belongs to t_step + i T."""

    reading: Reading
    t_step: float
    point: Point | None = None              # the reading, taken at the end of the window
    values: dict[int, float] = dataclasses.field(default_factory=dict)
    latest: float = -float('inf')           # latest sample stamp seen, s

    @property
    def n(self) -> int:
        """Samples in the window: record_s / T."""
        return int(round(self.reading.record_s / self.reading.sample_period_s))

    def add(self, t_s: float, force_n: float) -> None:
        """Put a load-cell sample (stamp s, N) in its slot; outside the window it is ignored."""
        period = self.reading.sample_period_s
        i = int(round((t_s - self.t_step) / period))
        if 0 <= i < self.n and abs(t_s - self.t_step - i * period) <= 0.5 * period:
            self.values.setdefault(i, force_n)
        self.latest = max(self.latest, t_s)

    def add_many(self, samples: list[tuple[float, float]]) -> None:
        """``add`` of every (stamp s, N) sample in order, the slots computed in one batch."""
        if not samples:
            return
        t = np.array([ts for ts, _ in samples])
        period = self.reading.sample_period_s
        idx = np.round((t - self.t_step) / period)
        keep = (idx >= 0) & (idx < self.n) & (np.abs(t - self.t_step - idx * period)
                                             <= 0.5 * period)
        values = self.values
        for i, (_, f) in zip(idx[keep].astype(int).tolist(),
                             (s for s, k in zip(samples, keep.tolist(), strict=True) if k),
                             strict=True):
            values.setdefault(i, f)
        self.latest = max(self.latest, float(t.max()))

    @property
    def complete(self) -> bool:
        """Every sample in, or a sample stamped past the window's last slot seen."""
        last = self.t_step + (self.n - 0.5) * self.reading.sample_period_s
        return len(self.values) == self.n or self.latest >= last

    def samples(self) -> tuple[float, ...]:
        """Every sample; a missing one (a real bench may drop one) holds the one before."""
        out, held = [], self.values.get(min(self.values), 0.0) if self.values else 0.0
        for i in range(self.n):
            held = self.values.get(i, held)
            out.append(held)
        return tuple(out)

    def finished(self) -> StepRecord:
        """The record handed out (its point must be taken)."""
        assert self.point is not None
        return StepRecord(self.point, self.t_step, self.samples())
