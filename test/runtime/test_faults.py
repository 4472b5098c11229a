"""A device's injected faults count from the run's start that the protocol status states, not
from the first status to arrive: a status missed while discovery was still matching must not
shift a fault (CI once saw a valve_stuck fault land a reading late and pass unseen)."""

from __future__ import annotations

import time
from typing import Any

import pytest
from pam_bench_interfaces.msg import ProtocolStatus
from rclpy.parameter import Parameter

from pam_bench.nodes.valve_sim import ValveSim


@pytest.mark.parametrize('elapsed_s', [0.0, 1.5, 4.0])
def test_fault_time_counts_from_the_start_the_status_states(make_harness: Any,
                                                            elapsed_s: float) -> None:
    h = make_harness(lambda ctx: ValveSim('valve_1', context=ctx, parameter_overrides=[
        Parameter('lockstep', value=False), Parameter('rate_hz', value=200.0),
        Parameter('faults_yaml', value='[{kind: valve_stuck, target: valve_1, at_s: 9.0, '
                                       'duration_s: 1.0}]')]))
    h.publisher(ProtocolStatus, '/protocol/status')
    h.add_node()
    node = h.node
    assert node is not None
    assert node.fault_time_s() == -1.0                  # before the run starts
    h.spin_until(lambda: h.pubs['/protocol/status'].get_subscription_count() > 0)
    h.send('/protocol/status', ProtocolStatus(state=1, elapsed=elapsed_s), 0)
    sent = time.monotonic()
    h.spin_until(lambda: node._fault_epoch_ns is not None)
    late_s = time.monotonic() - sent
    first = node.stepping.last_ns
    h.spin_until(lambda: node.stepping.last_ns != first)        # a step after the status
    assert elapsed_s - 0.05 <= node.fault_time_s() <= elapsed_s + late_s + 0.5
    h.send('/protocol/status', ProtocolStatus(state=1, elapsed=elapsed_s + 30.0), 0)
    until = time.monotonic() + 0.3
    h.spin_until(lambda: time.monotonic() > until)
    assert node.fault_time_s() < elapsed_s + 30.0       # the first status sets the start
