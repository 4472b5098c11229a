"""The reading window: a reading averages the samples of its last ``window_s``, not one sample.

A real bench reads the load cell and the encoder over a short window at the end of the dwell
(004 reads its characteristics after a dwell; one 1 kHz sample would let a single noise burst
through). ``SampleWindow`` keeps the recent (stamp, value) samples of one input, at most
``keep_s`` of them (fixed memory on a six-hour run), and averages those stamped in
(t - window_s, t]. A sample outside the input's band (the suspenders' [low, high] for it) is
left out of the average and handed back, to be written up with the reading or to suspend the
run (``RunnerSettings.reading_outliers``).
"""

from __future__ import annotations

import collections
import dataclasses
import math

__all__ = ['SampleWindow', 'Windowed', 'READING_WINDOW_S']

READING_WINDOW_S = 0.05
"""Default ``reading_window_s`` of a protocol, s."""
_EPS = 1e-9


@dataclasses.dataclass(frozen=True)
class Windowed:
    """An average over a window: the mean of the samples in band, how many went in, and the
    (stamp s, value) of each sample left out for being outside the band."""

    value: float
    n: int
    outliers: tuple[tuple[float, float], ...] = ()


class SampleWindow:
    """Recent samples of one input (module docstring).

    Args:
        keep_s: how much history to keep, s (at least the longest window asked for).
    """

    def __init__(self, keep_s: float = 1.0) -> None:
        self.keep_s = keep_s
        self._samples: collections.deque[tuple[float, float]] = collections.deque()

    def __len__(self) -> int:
        return len(self._samples)

    def add(self, samples: list[tuple[float, float]]) -> None:
        """Append (stamp s, value) samples (in stamp order) and forget those older than
        ``keep_s`` before the newest."""
        q = self._samples
        q.extend(samples)
        if q:
            oldest = q[-1][0] - self.keep_s
            while q and q[0][0] < oldest:
                q.popleft()

    def average(self, t_s: float, window_s: float, latest: float,
                band: tuple[float, float] = (-math.inf, math.inf)) -> Windowed:
        """Mean of the samples stamped in (t_s - window_s, t_s] inside ``band``; ``latest``
        when none is (a window shorter than the sample period, or no samples)."""
        low, high = band
        inside: list[float] = []
        out: list[tuple[float, float]] = []
        for t, v in reversed(self._samples):
            if t > t_s + _EPS:
                continue
            if t <= t_s - window_s + _EPS:
                break
            if low <= v <= high and math.isfinite(v):
                inside.append(v)
            else:
                out.append((t, v))
        if not inside:
            return Windowed(latest, 0, tuple(reversed(out)))
        return Windowed(math.fsum(inside) / len(inside), len(inside), tuple(reversed(out)))
