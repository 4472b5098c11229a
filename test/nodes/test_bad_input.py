"""Bad commands are rejected, logged, counted on /diagnostics; the device goes safe."""

from __future__ import annotations

import math
from typing import Any

import pytest
from pam_bench_interfaces.msg import MuscleState, PressureSamples, ValveCommand
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import FluidPressure

from pam_bench.models.constants import ATMOSPHERE_PA
from pam_bench.nodes.valve_sim import ValveSim
from pam_bench.runtime.messages import time_of
from test.nodes.harness import Harness

MS = 10_000_000


@pytest.fixture
def valve(make_harness: Any) -> Any:
    h = make_harness(lambda ctx: ValveSim('valve_1', context=ctx, parameter_overrides=[
        Parameter('valve.order', value=0)]))
    h.publisher(ValveCommand, 'valve_1/command')
    h.publisher(MuscleState, 'sim/muscle_1/state')
    h.listen(FluidPressure, 'valve_1/pressure')
    h.start()
    h.send('sim/muscle_1/state', MuscleState(volume=1.1e-4), 0)   # published at t_0
    yield h


def stamped(h: Harness, topic: str, t_ns: int) -> Any:
    """Wait for the message on ``topic`` stamped ``t_ns`` and return it. Matched by stamp, not
    by count: under load the harness publishes a tick again before its acknowledgement
    arrives, and the node then sends that step's outputs a second time."""
    stamp = time_of(t_ns)
    h.spin_until(lambda: any(m.header.stamp == stamp for m in h.received[topic]))
    return [m for m in h.received[topic] if m.header.stamp == stamp][-1]


def step(h: Harness, k: int, voltage: float) -> float:
    """Send the inputs stamped t_(k-1), tick t_k, return the gauge pressure published at t_k."""
    h.send('valve_1/command', ValveCommand(voltage=voltage), (k - 1) * MS)
    h.send('sim/muscle_1/state', MuscleState(volume=1.1e-4), (k - 1) * MS)
    h.tick(k * MS)
    return stamped(h, 'valve_1/pressure', k * MS).fluid_pressure - ATMOSPHERE_PA


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


def test_repeated_tick_sends_the_outputs_again(valve: Harness) -> None:
    """The clock publishes a tick again when an acknowledgement is missing (a message lost at
    start-up): the participant re-sends that step's outputs and the step before's, identical,
    and acknowledges."""
    valve.tick(1 * MS)
    valve.spin_until(lambda: len(valve.received['valve_1/pressure']) >= 1)
    assert step(valve, 2, 5.0) == pytest.approx(5e5)
    first = valve.received['valve_1/pressure'][-1]
    acks = valve.acks.count(2 * MS)
    before = [(m.header.stamp, m.fluid_pressure) for m in valve.received['valve_1/pressure']]
    n = len(before)
    valve.clock_pub.publish(Clock(clock=time_of(2 * MS)))
    valve.spin_until(lambda: valve.acks.count(2 * MS) > acks)
    valve.spin_until(lambda: len(valve.received['valve_1/pressure']) >= n + 2)
    again = [(m.header.stamp, m.fluid_pressure)
             for m in valve.received['valve_1/pressure'][n:]]
    # this step's output, and the step before's (a lagged consumer such as the recorder needs
    # that one at this tick), both identical to what went out first
    assert again == before[-2:]
    assert again[-1] == (first.header.stamp, first.fluid_pressure)
    assert [s for s, _ in again] == [time_of(1 * MS), time_of(2 * MS)]
    valve.send('valve_1/command', ValveCommand(voltage=2.0), 2 * MS)   # and the run goes on
    valve.send('sim/muscle_1/state', MuscleState(volume=1.1e-4), 2 * MS)
    valve.tick(3 * MS)
    valve.spin_until(lambda: valve.received['valve_1/pressure'][-1].header.stamp
                     == time_of(3 * MS))
    assert valve.received['valve_1/pressure'][-1].fluid_pressure - ATMOSPHERE_PA \
        == pytest.approx(2e5)


def test_valve_publishes_sub_step_samples(valve: Harness) -> None:
    """Every exchange: one FluidPressure at its end and one PressureSamples with the pressure
    at the end of every sub-step (sub_step_s, or the command's sample_period in a record)."""
    valve.listen(PressureSamples, 'sim/valve_1/samples')
    valve.tick(1 * MS)
    valve.spin_until(lambda: len(valve.received['valve_1/pressure']) >= 1)
    valve.send('valve_1/command', ValveCommand(voltage=4.0, sample_period=0.001), 1 * MS)
    valve.send('sim/muscle_1/state', MuscleState(volume=1.1e-4), 1 * MS)
    valve.tick(2 * MS)
    rec = stamped(valve, 'sim/valve_1/samples', 2 * MS)
    assert rec.record and list(rec.step) == pytest.approx([0.001] * 10)
    assert list(rec.pressure) == pytest.approx([4e5] * 10)
    assert len({m.header.stamp.nanosec for m in valve.received['valve_1/pressure']}) == 2
    valve.send('valve_1/command', ValveCommand(voltage=3.0), 2 * MS)
    valve.send('sim/muscle_1/state', MuscleState(volume=1.1e-4), 2 * MS)
    valve.tick(3 * MS)
    rec = stamped(valve, 'sim/valve_1/samples', 3 * MS)
    assert not rec.record and list(rec.step) == pytest.approx([0.005, 0.005])   # sub_step_s
