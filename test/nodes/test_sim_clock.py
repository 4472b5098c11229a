"""The run's ETA rate (nodes.sim_clock.windowed_rate)."""

from __future__ import annotations

import collections

import numpy as np
import pytest

from pam_bench.nodes.sim_clock import windowed_rate


@pytest.mark.parametrize(('fast_s', 'slow_rate', 'window_s', 'expected'), [
    (100.0, 10.0, 30.0, 10.0),     # a slow phase longer than the window: its own rate
    (100.0, 10.0, 200.0, None),    # window covers everything: the mean rate of the run
    (0.0, 10.0, 30.0, 10.0),       # one phase only
])
def test_rate_follows_the_last_window(fast_s: float, slow_rate: float, window_s: float,
                                      expected: float | None) -> None:
    """100x real time for ``fast_s`` of wall time, then ``slow_rate`` for 60 s, sampled at 2 s."""
    history: collections.deque[tuple[float, float]] = collections.deque()
    rate = 0.0
    for wall in np.arange(0.0, fast_s + 60.0 + 1e-9, 2.0):
        sim = 100.0 * min(wall, fast_s) + slow_rate * max(wall - fast_s, 0.0)
        rate = windowed_rate(history, float(wall), float(sim), window_s)
    if expected is None:
        expected = (100.0 * fast_s + slow_rate * 60.0) / (fast_s + 60.0)
    np.testing.assert_allclose(rate, expected, rtol=1e-12)


def test_rate_is_zero_before_wall_time_passes() -> None:
    history: collections.deque[tuple[float, float]] = collections.deque()
    assert windowed_rate(history, 5.0, 0.0) == 0.0
    assert windowed_rate(history, 5.0, 1.0) == 0.0
