"""Managed nodes on a wall clock: lifecycle services, stepping only when active, deactivation
that vents or turns the drive off at once, a configure that fails with its reason; a node
started by hand (``managed: false``) activates itself; in lock-step nothing is managed."""

from __future__ import annotations

import time
from typing import Any

import pytest
import rclpy
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetState
from pam_bench_interfaces.msg import ValveCommand
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter

from pam_bench.nodes.servo_canopen import ServoCanopenNode
from pam_bench.nodes.torque_servo import TorqueServoNode
from pam_bench.nodes.valve_sim import ValveSim

pytestmark = pytest.mark.wallclock

WALL = [Parameter('lockstep', value=False)]


class Manager:
    """A lifecycle manager as ``ros2 lifecycle set`` is one: service calls from its own node."""

    def __init__(self, ctx: rclpy.Context, node: Any) -> None:
        self.node = node
        self.me = rclpy.create_node('manager', context=ctx)
        self.executor = SingleThreadedExecutor(context=ctx)
        self.executor.add_node(node)
        self.executor.add_node(self.me)
        name = node.get_name()
        self.change = self.me.create_client(ChangeState, f'/{name}/change_state')
        self.get = self.me.create_client(GetState, f'/{name}/get_state')
        self.seen: list[Any] = []

    def call(self, client: Any, request: Any) -> Any:
        assert client.wait_for_service(timeout_sec=10.0)
        future = client.call_async(request)
        self.executor.spin_until_future_complete(future, timeout_sec=10.0)
        return future.result()

    def set(self, transition: int) -> bool:
        return bool(self.call(self.change, ChangeState.Request(
            transition=Transition(id=transition))).success)

    def state(self) -> str:
        return str(self.call(self.get, GetState.Request()).current_state.label)

    def ticks(self, n: int) -> None:
        """``n`` wall ticks of the node, 1 ms apart, its callbacks served in between."""
        for _ in range(n):
            self.node.wall_tick()
            self.executor.spin_once(timeout_sec=0.001)

    def close(self) -> None:
        self.executor.shutdown()
        self.me.destroy_node()
        self.node.destroy_node()


def _valve(ctx: rclpy.Context, managed: bool) -> ValveSim:
    node = ValveSim('valve_1', context=ctx, parameter_overrides=[
        *WALL, Parameter('managed', value=managed)])
    node.take_wall_ticks()                     # ticked by the test
    return node


def _count_steps(node: Any) -> list[int]:
    """Count the node's steps (``on_wall_tick`` calls past its lifecycle's gate)."""
    steps: list[int] = []
    step = node.on_wall_tick
    node.on_wall_tick = lambda t_ns=None: (steps.append(1), step(t_ns))
    return steps


def test_a_managed_valve_steps_only_when_active_and_vents_when_deactivated(
        context: rclpy.Context, own: Any) -> None:
    node = _valve(context, managed=True)
    steps = _count_steps(node)
    m = own(Manager(context, node))
    assert m.state() == 'unconfigured'
    m.ticks(20)
    assert not steps and node.lifecycle_state == 'unconfigured'  # waits for its manager
    assert m.set(Transition.TRANSITION_CONFIGURE) and m.state() == 'inactive'
    m.ticks(20)
    assert not steps
    assert m.set(Transition.TRANSITION_ACTIVATE) and m.state() == 'active'
    m.ticks(20)
    assert len(steps) == 20
    node.voltage_v = 6.0                      # as a command and a muscle would leave it
    node.model.reset(3.0e5)
    assert m.set(Transition.TRANSITION_DEACTIVATE) and m.state() == 'inactive'
    assert node.voltage_v == 0.0 and node.model.state[0] == 0.0   # vented at once
    m.ticks(20)
    assert len(steps) == 20                   # no stepping while inactive
    assert m.set(Transition.TRANSITION_ACTIVATE)
    m.ticks(5)
    assert len(steps) == 25


def test_a_node_started_by_hand_activates_itself_at_its_first_tick(
        context: rclpy.Context, own: Any) -> None:
    node = _valve(context, managed=False)
    steps = _count_steps(node)
    m = own(Manager(context, node))
    assert m.state() == 'unconfigured'
    m.ticks(3)
    assert len(steps) == 3 and m.state() == 'active'


def test_in_lockstep_a_device_is_not_managed(context: rclpy.Context, own: Any) -> None:
    node = own(ValveSim('valve_1', context=context))
    assert not node.managed and node.lifecycle_state == 'active' and node.may_step()
    assert not [s for s in node.services if 'change_state' in s.srv_name]


def test_a_deactivated_servo_vents_both_valves(context: rclpy.Context, own: Any) -> None:
    node = TorqueServoNode('torque_servo', context=context, parameter_overrides=[
        *WALL, Parameter('controller', value='pid'), Parameter('managed', value=True)])
    m = own(Manager(context, node))
    got: dict[int, list[ValveCommand]] = {1: [], 2: []}
    for ch in (1, 2):
        m.me.create_subscription(ValveCommand, f'/valve_{ch}/command', got[ch].append, 10)
    assert m.set(Transition.TRANSITION_CONFIGURE)
    assert m.set(Transition.TRANSITION_ACTIVATE)
    assert m.set(Transition.TRANSITION_DEACTIVATE)
    end = time.monotonic() + 5.0
    while not (got[1] and got[2]) and time.monotonic() < end:
        m.executor.spin_once(timeout_sec=0.01)
    assert got[1] and got[2]
    assert got[1][-1].voltage == got[2][-1].voltage == 0.0


def test_a_drive_that_cannot_be_reached_fails_its_configure_with_the_reason(
        context: rclpy.Context, own: Any) -> None:
    node = ServoCanopenNode('servo_canopen', context=context, parameter_overrides=[
        Parameter('managed', value=True),
        Parameter('can_channel', value='pamnone0')])     # no such CAN interface here
    node.take_wall_ticks()
    m = own(Manager(context, node))
    assert not m.set(Transition.TRANSITION_CONFIGURE)
    assert m.state() == 'unconfigured'
    why = node.diagnostics.concerns['lifecycle']
    assert why.level == b'\x02' and why.message.startswith('configure failed:'), why
    m.ticks(5)
    assert node.lifecycle_state == 'unconfigured' and node.exit_code is None


def test_started_by_hand_a_drive_that_cannot_be_reached_ends_its_process(
        context: rclpy.Context, own: Any) -> None:
    node = own(ServoCanopenNode('servo_canopen', context=context, parameter_overrides=[
        Parameter('can_channel', value='pamnone0')]))
    node.take_wall_ticks()
    node.wall_tick()
    assert node.exit_code == 2 and node.lifecycle_state == 'unconfigured'
    assert node.diagnostics.concerns['lifecycle'].message.startswith('configure failed:')


def test_a_managed_servo_counts_its_startup_timeout_from_its_activation(
        context: rclpy.Context, own: Any) -> None:
    """The startup gate sits on the lifecycle: however long the manager takes, the servo's
    ``startup_timeout_s`` for its inputs starts when it is activated."""
    node = TorqueServoNode('torque_servo', context=context, parameter_overrides=[
        *WALL, Parameter('controller', value='pid'), Parameter('managed', value=True),
        Parameter('startup_timeout_s', value=0.2)])
    node.take_wall_ticks()
    m = own(Manager(context, node))
    end = time.monotonic() + 0.5                  # unconfigured for longer than 0.2 s
    while time.monotonic() < end:
        m.ticks(5)
    assert node.exit_code is None
    assert m.set(Transition.TRANSITION_CONFIGURE) and m.set(Transition.TRANSITION_ACTIVATE)
    m.ticks(2)
    assert node.exit_code is None                 # just activated: still within 0.2 s
    end = time.monotonic() + 0.5
    while time.monotonic() < end and node.exit_code is None:
        m.ticks(5)
    assert node.exit_code == 3                    # no inputs for 0.2 s once active


def _recorded_valve(ctx: rclpy.Context) -> ValveSim:
    node = ValveSim('valve_1', context=ctx, parameter_overrides=[
        *WALL, Parameter('managed', value=True), Parameter('await_recorder', value=True)])
    node.take_wall_ticks()
    return node


def test_a_managed_node_configures_once_a_recorder_that_just_came_hears_it(
        context: rclpy.Context, context_with: Any, own: Any) -> None:
    """The recorder's participant appears just before the manager calls: without the wait,
    the 'configured' diagnostic goes out before the recorder is matched and is lost."""
    from diagnostic_msgs.msg import DiagnosticArray
    node = _recorded_valve(context)
    m = own(Manager(context, node))
    rec_ctx = context_with([])                    # another participant, as a process is
    heard: list[str] = []
    assert m.state() == 'unconfigured'
    recorder = own(rclpy.create_node('recorder', context=rec_ctx))
    recorder.create_subscription(DiagnosticArray, '/diagnostics', lambda a: heard.extend(
        s.message for s in a.status if s.name.endswith(': lifecycle')), 10)
    assert m.set(Transition.TRANSITION_CONFIGURE)
    rec_exec = SingleThreadedExecutor(context=rec_ctx)
    rec_exec.add_node(recorder)
    end = time.monotonic() + 5.0
    while not heard and time.monotonic() < end:
        rec_exec.spin_once(timeout_sec=0.01)
    assert heard[:1] == ['configured']
    assert 'recorder' not in node.diagnostics.concerns      # no warning: it was heard


def test_a_managed_node_with_no_recorder_configures_after_its_wait_and_says_so(
        context: rclpy.Context, own: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    from pam_bench.runtime import lifecycle
    monkeypatch.setattr(lifecycle, 'RECORDER_WAIT_S', 0.2)
    node = _recorded_valve(context)
    m = own(Manager(context, node))
    t0 = time.monotonic()
    assert m.set(Transition.TRANSITION_CONFIGURE) and m.state() == 'inactive'
    assert time.monotonic() - t0 >= 0.2
    warn = node.diagnostics.concerns['recorder']
    assert warn.level == b'\x01' and warn.message.startswith('no recorder on /diagnostics')
