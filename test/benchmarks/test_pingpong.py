"""The lock-step floor with no work: N separate processes acknowledge every tick."""

from __future__ import annotations

import pytest

from pam_bench.benchmarks.pingpong import fanout_rate


@pytest.mark.parametrize('participants', [1, 3])
def test_fanout_completes_and_gives_a_rate(ros_domain: int, participants: int) -> None:
    """Every tick is acknowledged by all participants (the count is reached, else it raises);
    the rate is finite and positive."""
    rate = fanout_rate(participants, count=200, warmup=20)
    assert 0.0 < rate < 1e6
