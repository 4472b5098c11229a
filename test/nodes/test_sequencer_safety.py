"""Sequencer on a wall clock (as on a real bench): stale input aborts, cancel vents."""

from __future__ import annotations

import time
from typing import Any

import pytest
from action_msgs.msg import GoalStatus
from geometry_msgs.msg import WrenchStamped
from pam_bench_interfaces.action import RunProtocol
from pam_bench_interfaces.msg import LoadCommand, ProtocolStatus, ValveCommand
from rclpy.action import ActionClient
from rclpy.parameter import Parameter
from sensor_msgs.msg import FluidPressure, JointState

from pam_bench.models.constants import ATMOSPHERE_PA
from pam_bench.nodes.sequencer import SequencerNode
from test.nodes.harness import Harness

pytestmark = pytest.mark.wallclock


def make(autostart: bool, **extra: object):
    values = {'lockstep': False, 'autostart': autostart, 'protocol': 'isometric_quick',
              'tick_period_s': 0.01, 'stale_timeout_s': 0.2, 'status_period_s': 0.05, **extra}

    def factory(ctx):
        return SequencerNode('sequencer', context=ctx, parameter_overrides=[
            Parameter(k, value=v) for k, v in values.items()])
    return factory


@pytest.fixture
def harness_factory(make_harness: Any) -> Any:
    def build(autostart: bool, **extra: object) -> Harness:
        h = make_harness(make(autostart, **extra))
        h.publisher(WrenchStamped, 'load_cell_1/force')
        h.publisher(JointState, 'encoder/joint_state')
        h.publisher(FluidPressure, 'valve_1/pressure')
        h.publisher(JointState, 'loading_servo/state')
        h.listen(ProtocolStatus, 'protocol/status')
        h.listen(ValveCommand, 'valve_1/command')
        h.listen(LoadCommand, 'loading_servo/command')
        h.add_node()
        return h
    return build


def feed(h: Harness, seconds: float, with_force: bool = True) -> None:
    """Publish measurements stamped with the wall clock for ``seconds``."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        now = h.tester.get_clock().now().nanoseconds
        if with_force:
            h.send('load_cell_1/force', WrenchStamped(), now)
        h.send('encoder/joint_state', JointState(name=['pulley'], position=[0.0]), now)
        h.send('valve_1/pressure', FluidPressure(fluid_pressure=ATMOSPHERE_PA), now)
        h.send('loading_servo/state', JointState(name=['motor'], position=[0.0],
                                                 velocity=[0.0], effort=[0.0]), now)
        h.executor.spin_once(timeout_sec=0.005)


def test_stale_load_cell_aborts_and_vents(harness_factory) -> None:
    h = harness_factory(True)
    feed(h, 0.5)
    running = [s for s in h.received['protocol/status'] if s.state == ProtocolStatus.STATE_RUNNING]
    assert running, 'the protocol did not start'
    feed(h, 1.0, with_force=False)                       # the load cell stops publishing
    aborted = [s for s in h.received['protocol/status'] if s.state == ProtocolStatus.STATE_ABORTED]
    assert aborted and 'load_cell_1/force' in aborted[0].reason and 'stale' in aborted[0].reason
    assert h.received['valve_1/command'][-1].voltage == 0.0
    assert h.received['loading_servo/command'][-1].mode == LoadCommand.MODE_OFF


def test_nan_from_a_driver_is_rejected_and_vents(harness_factory) -> None:
    # the NaN is what this test judges: a loaded machine that delivers it 0.2 s late must not
    # abort the run for staleness first (it did once, in CI)
    h = harness_factory(True, stale_timeout_s=2.0)
    feed(h, 0.5)

    def aborted() -> list[ProtocolStatus]:
        return [s for s in h.received['protocol/status']
                if s.state == ProtocolStatus.STATE_ABORTED]
    end = time.monotonic() + 10.0              # a loaded machine delivers late: until it ends
    while not aborted() and time.monotonic() < end:   # the load cell driver sends NaN
        now = h.tester.get_clock().now().nanoseconds
        bad = WrenchStamped()
        bad.wrench.force.x = float('nan')
        h.send('load_cell_1/force', bad, now)
        h.executor.spin_once(timeout_sec=0.005)
    feed(h, 0.2)
    assert aborted() and 'not finite' in aborted()[0].reason
    assert h.node.rejected_count > 0
    assert any('rejected' in st.message for d in h.diagnostics for st in d.status)
    assert h.received['valve_1/command'][-1].voltage == 0.0
    assert h.received['loading_servo/command'][-1].mode == LoadCommand.MODE_OFF


def test_cancel_stops_and_vents(harness_factory) -> None:
    h = harness_factory(False)
    client = ActionClient(h.tester, RunProtocol, 'protocol/run')
    h.spin_until(lambda: client.server_is_ready())
    feedback = []
    send = client.send_goal_async(RunProtocol.Goal(protocol='isometric_quick'),
                                  feedback_callback=lambda m: feedback.append(m.feedback))
    h.spin_until(send.done)
    goal = send.result()
    assert goal.accepted
    end = time.monotonic() + 0.6
    while time.monotonic() < end:
        feed(h, 0.05)
    assert feedback and feedback[-1].points_total == 42
    cancel = goal.cancel_goal_async()
    h.spin_until(cancel.done)
    result = goal.get_result_async()
    while not result.done():
        feed(h, 0.05)
    assert result.result().status == GoalStatus.STATUS_CANCELED
    assert not result.result().result.success
    feed(h, 0.1)
    states = [s.state for s in h.received['protocol/status']]
    assert ProtocolStatus.STATE_CANCELLED in states
    assert h.received['valve_1/command'][-1].voltage == 0.0
    assert h.received['loading_servo/command'][-1].mode == LoadCommand.MODE_OFF


def test_unknown_protocol_goal_rejected(harness_factory) -> None:
    h = harness_factory(False)
    client = ActionClient(h.tester, RunProtocol, 'protocol/run')
    h.spin_until(lambda: client.server_is_ready())
    send = client.send_goal_async(RunProtocol.Goal(protocol='no_such_protocol'))
    h.spin_until(send.done)
    assert not send.result().accepted


def test_pause_and_resume_services_and_a_suspender(harness_factory) -> None:
    from std_srvs.srv import Trigger
    h = harness_factory(True, stale_timeout_s=0.5, pause_action='vent',
                        suspenders_yaml='[{input: force, low: -20.0, high: 1500.0, '
                        'resume_after_s: 0.3}]')
    feed(h, 0.5)

    def call(name: str) -> Trigger.Response:
        client = h.tester.create_client(Trigger, f'protocol/{name}')
        h.spin_until(client.service_is_ready)
        fut = client.call_async(Trigger.Request())
        h.spin_until(fut.done)
        return fut.result()

    assert call('pause').success
    feed(h, 0.3)
    last = h.received['protocol/status'][-1]
    assert last.phase == 'paused' and 'operator' in last.reason
    assert h.received['valve_1/command'][-1].voltage == 0.0              # vented
    assert h.received['loading_servo/command'][-1].mode == LoadCommand.MODE_OFF
    assert call('resume').success
    feed(h, 0.3)
    assert h.received['protocol/status'][-1].phase == 'settle'     # vented: settles again
    # a suspender: the force leaves its band, the run pauses by itself, then resumes
    end = time.monotonic() + 0.3
    while time.monotonic() < end:
        now = h.tester.get_clock().now().nanoseconds
        m = WrenchStamped()
        m.wrench.force.x = -100.0
        h.send('load_cell_1/force', m, now)
        h.send('encoder/joint_state', JointState(name=['pulley'], position=[0.0]), now)
        h.send('valve_1/pressure', FluidPressure(fluid_pressure=ATMOSPHERE_PA), now)
        h.send('loading_servo/state', JointState(name=['motor'], position=[0.0],
                                                 velocity=[0.0], effort=[0.0]), now)
        h.executor.spin_once(timeout_sec=0.005)
    last = h.received['protocol/status'][-1]
    assert last.phase == 'paused' and 'suspended' in last.reason and 'force' in last.reason
    assert not call('resume').success                  # the suspender holds the run
    feed(h, 0.8)                                          # good again for 0.3 s
    phases = [s.phase for s in h.received['protocol/status']]
    assert phases[-1] == 'settle' and last.state == ProtocolStatus.STATE_RUNNING
    assert any('suspended' in st.message for d in h.diagnostics for st in d.status)


def _goal(h: Harness, client: ActionClient, protocol: str = 'isometric_quick'):
    send = client.send_goal_async(RunProtocol.Goal(protocol=protocol))
    h.spin_until(send.done)
    goal = send.result()
    assert goal.accepted
    return goal


def _spin(h: Harness, seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        h.executor.spin_once(timeout_sec=0.01)


def test_cancel_while_waiting_for_inputs_ends_the_goal_cancelled(harness_factory) -> None:
    h = harness_factory(False)
    client = ActionClient(h.tester, RunProtocol, 'protocol/run')
    h.spin_until(lambda: client.server_is_ready())
    goal = _goal(h, client)
    _spin(h, 0.2)                                       # no device publishes: it waits
    waiting = [s for s in h.received['protocol/status'] if 'waiting for' in s.reason]
    assert waiting and waiting[-1].state == ProtocolStatus.STATE_IDLE
    cancel = goal.cancel_goal_async()
    h.spin_until(cancel.done)
    result = goal.get_result_async()
    h.spin_until(result.done, timeout_s=5.0)
    assert result.result().status == GoalStatus.STATUS_CANCELED
    assert h.received['valve_1/command'][-1].voltage == 0.0
    assert h.received['loading_servo/command'][-1].mode == LoadCommand.MODE_OFF
    assert h.node.exit_code is None                       # the server stays up


def test_startup_timeout_aborts_the_goal_and_keeps_the_server(harness_factory) -> None:
    h = harness_factory(False, startup_timeout_s=0.3)
    client = ActionClient(h.tester, RunProtocol, 'protocol/run')
    h.spin_until(lambda: client.server_is_ready())
    _spin(h, 0.5)                 # idle longer than the timeout: no goal, nothing to abort
    goal = _goal(h, client)
    result = goal.get_result_async()
    h.spin_until(result.done, timeout_s=5.0)
    assert result.result().status == GoalStatus.STATUS_ABORTED
    assert 'no data on' in result.result().result.reason
    assert h.node.exit_code is None
    goal = _goal(h, client)                     # the next goal is served, and runs
    end = time.monotonic() + 0.5
    while time.monotonic() < end:
        feed(h, 0.05)
    assert h.received['protocol/status'][-1].state == ProtocolStatus.STATE_RUNNING
    cancel = goal.cancel_goal_async()
    h.spin_until(cancel.done)
    result = goal.get_result_async()
    while not result.done():
        feed(h, 0.05)
    assert result.result().status == GoalStatus.STATUS_CANCELED


def test_status_is_latched_for_a_late_joiner(harness_factory) -> None:
    from pam_bench.runtime.qos import LATCHED
    h = harness_factory(False, status_period_s=30.0)
    _spin(h, 0.3)                                   # one idle status, then none for 30 s
    got: list[ProtocolStatus] = []
    h.tester.create_subscription(ProtocolStatus, 'protocol/status', got.append, LATCHED)
    h.spin_until(lambda: bool(got), timeout_s=5.0)
    assert got[0].state == ProtocolStatus.STATE_IDLE and got[0].protocol == ''
