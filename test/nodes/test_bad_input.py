"""Bad commands are rejected, logged, counted on /diagnostics; the device goes safe."""

from __future__ import annotations

import math

import pytest
from pam_bench_interfaces.msg import MuscleState, ValveCommand
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import FluidPressure

from pam_bench.nodes.base import time_of
from pam_bench.nodes.valve_sim import ATMOSPHERE_PA, ValveSim
from test.nodes.harness import Harness

MS = 10_000_000


@pytest.fixture
def valve(ros_domain: int):
    h = Harness(lambda ctx: ValveSim('valve_1', context=ctx, parameter_overrides=[
        Parameter('valve.order', value=0)]))
    try:
        h.publisher(ValveCommand, 'valve_1/command')
        h.publisher(MuscleState, 'sim/muscle_1/state')
        h.listen(FluidPressure, 'valve_1/pressure')
        h.start()
        yield h
    finally:
        h.close()


def step(h: Harness, k: int, voltage: float) -> float:
    """Send the inputs stamped t_(k-1), tick t_k, return the gauge pressure published."""
    h.send('valve_1/command', ValveCommand(voltage=voltage), (k - 1) * MS)
    h.send('sim/muscle_1/state', MuscleState(volume=1.1e-4), (k - 1) * MS)
    h.tick(k * MS)
    h.spin_until(lambda: len(h.received['valve_1/pressure']) >= k)
    return h.received['valve_1/pressure'][-1].fluid_pressure - ATMOSPHERE_PA


@pytest.mark.parametrize('bad', [math.nan, math.inf, -1.0, 10.5])
def test_bad_voltage_rejected_and_valve_vents(valve: Harness, bad: float) -> None:
    valve.tick(1 * MS)                                    # step 1 runs on initial values
    valve.spin_until(lambda: len(valve.received['valve_1/pressure']) >= 1)
    assert step(valve, 2, 5.0) == pytest.approx(5e5)
    assert step(valve, 3, bad) == pytest.approx(0.0)      # vented
    valve.spin_until(lambda: any('rejected' in s.message for d in valve.diagnostics
                                 for s in d.status))
    status = [s for d in valve.diagnostics for s in d.status if 'rejected' in s.message][-1]
    assert dict((kv.key, kv.value) for kv in status.values)['rejected_count'] == '1'
    assert valve.node.rejected_count == 1
    assert step(valve, 4, 3.0) == pytest.approx(3e5)      # a valid command is obeyed again


def test_clock_jumping_backwards_is_ignored(valve: Harness) -> None:
    """/clock going back (a reset of the sim clock) must not step the device again, publish
    stale outputs or raise; the next forward tick steps normally."""
    valve.tick(1 * MS)
    valve.spin_until(lambda: len(valve.received['valve_1/pressure']) >= 1)
    assert step(valve, 2, 5.0) == pytest.approx(5e5)
    published = len(valve.received['valve_1/pressure'])
    for t in (1 * MS, 0, 1 * MS):
        valve.clock_pub.publish(Clock(clock=time_of(t)))
        for _ in range(10):
            valve.executor.spin_once(timeout_sec=0.01)
    assert len(valve.received['valve_1/pressure']) == published
    assert not any('failed' in s.message for d in valve.diagnostics for s in d.status)
    assert step(valve, 3, 2.0) == pytest.approx(2e5)
