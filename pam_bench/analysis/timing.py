"""Timing of a periodic loop: how well a node kept its period on a wall clock.

A loop that should tick every ``T`` seconds is judged by its periods ``dt_k = t_k - t_(k-1)``
(from monotonic tick times, or from the header stamps of what it published): mean, median,
99th percentile and largest, and the share of periods more than ``late_s`` (0.5 ms by default)
longer than ``T``. Issue 16 asks for p99 <= 1.5 ms and under 1 % late at T = 1 ms.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ['period_stats', 'LATE_S']

LATE_S = 0.5e-3
"""A period this much longer than the nominal one counts as late (s)."""


def period_stats(times_ns: Sequence[int] | np.ndarray, period_s: float,
                 late_s: float = LATE_S) -> dict[str, float]:
    """Statistics of the periods between consecutive tick times.

    Args:
        times_ns: tick times, ns, shape (n,), increasing (n >= 2).
        period_s: the nominal period T, s.
        late_s: lateness beyond T that counts a period as late, s.

    Returns:
        ``ticks`` (n), ``period_s`` (T), ``mean_s``, ``p50_s``, ``p99_s``, ``max_s`` of the
        periods, ``max_at_s`` (when the longest one ended, from the first tick) and
        ``late_share`` (fraction of periods longer than T + late_s).

    Raises:
        ValueError: fewer than two ticks.
    """
    t = np.asarray(times_ns, dtype=np.int64)
    if t.size < 2:
        raise ValueError('period statistics need at least two ticks')
    dt = np.diff(t) * 1e-9
    return {'ticks': float(t.size), 'period_s': float(period_s), 'mean_s': float(dt.mean()),
            'p50_s': float(np.percentile(dt, 50)), 'p99_s': float(np.percentile(dt, 99)),
            'max_s': float(dt.max()),
            'max_at_s': float((t[int(dt.argmax()) + 1] - t[0]) * 1e-9),
            'late_share': float(np.mean(dt > period_s + late_s))}
