"""Loop periods: the streaming statistics in fixed memory agree with the array ones."""

from __future__ import annotations

import numpy as np
import pytest

from pam_bench.analysis.timing import LogHistogram, PeriodStats, period_stats


def test_streaming_statistics_match_the_whole_array_within_a_tenth_of_a_percent() -> None:
    rng = np.random.default_rng(3)
    dt = np.round(1e6 + rng.gamma(2.0, 5e4, 20000)).astype(np.int64)     # ns, ~1 ms loop
    dt[[500, 7000]] = [4_000_000, 12_500_000]                             # two stalls
    t = np.concatenate([[0], np.cumsum(dt)])
    ref = period_stats(t, 1e-3)
    ps = PeriodStats(1e-3)
    for v in t.tolist():
        ps.tick(v)
    got = ps.stats()
    assert got is not None
    for key in ('ticks', 'mean_s', 'max_s', 'max_at_s', 'late_share'):
        assert got[key] == pytest.approx(ref[key], rel=1e-12), key
    for key in ('p50_s', 'p99_s'):            # bucket middles: within 0.1 % of the exact ones
        assert got[key] == pytest.approx(ref[key], rel=1e-3), key


def test_memory_does_not_grow_with_the_run() -> None:
    h = LogHistogram()
    size = h.counts.nbytes
    for v in range(1, 200000, 7):
        h.record(v * 1000)
    assert h.counts.nbytes == size <= 256 * 1024
    assert h.value_at(1.0) == pytest.approx(199994 * 1000, rel=1e-3)
    assert LogHistogram().value_at(0.5) == 0.0
