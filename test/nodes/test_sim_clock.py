"""The sim clock: its ETA rate (nodes.sim_clock.windowed_rate), a tick sent again, its start."""

from __future__ import annotations

import collections
from typing import Any

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


@pytest.mark.wallclock
def test_an_unacknowledged_tick_is_published_again_and_again(make_harness: Any) -> None:
    """A tick nobody acknowledges goes out again every nudge_s (0.1 s here) until the stall
    timeout, not once: under load a reader can match later than the first nudge, and the
    outputs a participant sends again with it would be lost as the first ones were."""
    import time

    import rclpy
    from pam_bench_interfaces.msg import StepAck
    from rclpy.parameter import Parameter
    from rosgraph_msgs.msg import Clock

    from pam_bench.nodes.sim_clock import SimClock
    from pam_bench.runtime.base import RELIABLE
    from pam_bench.runtime.messages import ns_of, time_of

    h = make_harness(lambda ctx: SimClock(context=ctx, lean=False, parameter_overrides=[
        Parameter('participants', value=['/p']), Parameter('nudge_s', value=0.1),
        Parameter('grace_s', value=0.0), Parameter('exchange_step_s', value=0.01),
        Parameter('stall_timeout_s', value=20.0)]))
    ticks: list[int] = []
    h.tester.create_subscription(Clock, '/clock', lambda m: ticks.append(ns_of(m.clock)),
                                 RELIABLE)
    ack_pub = h.tester.create_publisher(StepAck, '/sim/ack', RELIABLE)
    h.add_node()
    h.spin_until(lambda: 0 in ticks)
    msg = StepAck(node='/p')
    msg.header.stamp = time_of(0)
    h.spin_until(lambda: (ack_pub.publish(msg), 10_000_000 in ticks)[1])
    end = time.monotonic() + 1.5
    while time.monotonic() < end:
        h.executor.spin_once(timeout_sec=0.02)
    assert rclpy.ok(context=h.context)
    assert ticks.count(10_000_000) >= 4, ticks      # once, then a nudge per 0.25 s timer


def test_in_one_process_the_clock_starts_at_the_poll_that_finds_every_ack(
        ros_domain: int) -> None:
    """Composed (lean, on the intra-process bus, no grace): t_0 goes out at the first poll,
    and the poll after the participants' acknowledgements starts the run at once, with no
    50 ms mark between (three such marks were 0.15 s of the demo's 1.5 s)."""
    import rclpy
    from pam_bench_interfaces.msg import StepAck
    from rclpy.parameter import Parameter

    from pam_bench.nodes.sim_clock import ClockState, SimClock
    from pam_bench.runtime.base import RELIABLE
    from pam_bench.runtime.intra import IntraProcessBus
    from pam_bench.runtime.messages import clock_ns, time_of

    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        bus = IntraProcessBus()
        clock = SimClock(context=context, lean=True, bus=bus, parameter_overrides=[
            Parameter('participants', value=['/p']), Parameter('grace_s', value=0.0),
            Parameter('exchange_step_s', value=0.01)])
        peer = rclpy.create_node('p', context=context)
        acks = bus.publisher(peer, StepAck, '/sim/ack', RELIABLE)
        ticks: list[int] = []

        def on_tick(msg: object) -> None:
            ticks.append(clock_ns(msg))
            ack = StepAck(node='/p')
            ack.header.stamp = time_of(ticks[-1])
            acks.publish(ack)

        bus.subscribe(peer, '/clock', on_tick, None)
        clock.lean_poll()                      # t_0 out at once
        bus.drain(100)                         # the peer acknowledges it
        assert ticks == [0] and clock.state == ClockState.WAITING
        clock.lean_poll()                      # every ack in: running, t_1 out
        assert clock.state == ClockState.RUNNING
        bus.drain(100)
        assert ticks[:2] == [0, 10_000_000]
    finally:
        rclpy.shutdown(context=context)
