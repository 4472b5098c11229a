"""Torque servo node: a short servo scene end to end, clamping, NaN, stale feedback vents."""

from __future__ import annotations

import dataclasses
import pathlib
import time
from typing import Any

import numpy as np
import pytest
from geometry_msgs.msg import WrenchStamped
from pam_bench_interfaces.msg import TorqueServoState, TorqueSetpoint, ValveCommand
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger

from pam_bench.analysis.servo_bag import read_servo_states
from pam_bench.bringup.runner import run_scene
from pam_bench.config.scene import load_scene
from pam_bench.nodes.torque_servo import TorqueServoNode
from pam_bench.vocabulary.run import RunOptions
from test.conftest import next_domain
from test.nodes.harness import Harness


def test_short_servo_scene_tracks_the_torque(tmp_path: pathlib.Path, ros_domain: int) -> None:
    """servo_sin_t for 1.5 s through the ten separate-process nodes: both muscles pull, the
    measured torque follows 5 sin t, the pair stays taut."""
    scene = dataclasses.replace(load_scene('servo_sin_t'), duration_s=1.5)
    res = run_scene(scene, str(tmp_path / 'bag'), RunOptions(domain_id=next_domain(), quiet=True))
    assert res.code == 0, res
    s = read_servo_states(tmp_path / 'bag')
    assert len(s['t_s']) == 1500                        # one state per 1 ms control period
    np.testing.assert_allclose(np.diff(s['t_s']), 1e-3, atol=1e-9)
    late = s['t_s'] >= s['t_s'][0] + 0.5
    err = s['torque_setpoint'][late] - s['torque_measured'][late]
    assert np.sqrt(np.mean(err ** 2)) < 0.25             # N m, of a 5 N m sine
    assert (s['force_measured'][late] > 20.0).all()      # both muscles taut
    assert all(st == '' for st in s['status'])


@pytest.fixture
def harness(make_harness: Any) -> Any:
    h = make_harness(lambda ctx: TorqueServoNode('torque_servo', context=ctx, parameter_overrides=[
        Parameter('lockstep', value=False), Parameter('controller', value='pid'),
        Parameter('control_period_s', value=0.005), Parameter('stale_timeout_s', value=0.25)]))
    for i in (1, 2):
        h.publisher(WrenchStamped, f'load_cell_{i}/force')
        h.listen(ValveCommand, f'valve_{i}/command')
    h.publisher(JointState, 'encoder/joint_state')
    h.publisher(TorqueSetpoint, 'torque_servo/setpoint')
    h.listen(TorqueServoState, 'torque_servo/state')
    h.add_node()
    yield h


def feed(h: Harness, seconds: float, forces: tuple[float, float] | None = (300.0, 300.0),
         setpoint: float | None = None) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        now = h.tester.get_clock().now().nanoseconds
        if forces is not None:
            for i, f in enumerate(forces, start=1):
                msg = WrenchStamped()
                msg.wrench.force.x = f
                h.send(f'load_cell_{i}/force', msg, now)
        h.send('encoder/joint_state', JointState(name=['pulley'], position=[0.0]), now)
        if setpoint is not None:
            h.send('torque_servo/setpoint', TorqueSetpoint(torque=setpoint), now)
        h.executor.spin_once(timeout_sec=0.002)


def feed_until(h: Harness, cond, timeout_s: float = 10.0, **kw) -> None:
    """Feed in slices of 0.1 s until ``cond()`` (discovery may take a moment)."""
    end = time.monotonic() + timeout_s
    while not cond():
        assert time.monotonic() < end, 'condition not met in time'
        feed(h, 0.1, **kw)


def running(h: Harness) -> bool:
    st = h.received['torque_servo/state']
    return bool(st) and st[-1].status == '' and h.received['valve_1/command'][-1].voltage > 0


@pytest.mark.wallclock
def test_setpoint_clamped_and_nan_rejected(harness: Harness) -> None:
    h = harness
    feed_until(h, lambda: running(h), setpoint=40.0)
    feed(h, 0.1, setpoint=40.0)
    last = [st for st in h.received['torque_servo/state'] if st.status == ''][-1]
    assert last.torque_setpoint == pytest.approx(25.46)          # clamped to the drive's range
    assert any('clamped' in st.message for d in h.diagnostics for st in d.status)
    feed(h, 0.2, setpoint=float('nan'))
    assert [st for st in h.received['torque_servo/state'] if st.status == ''][-1] \
        .torque_setpoint == pytest.approx(25.46)
    assert h.node.rejected_count > 0


@pytest.mark.wallclock
def test_stale_force_vents_both_valves(harness: Harness) -> None:
    h = harness
    feed_until(h, lambda: running(h), setpoint=2.0)
    feed(h, 0.8, forces=None)                                    # the load cells go quiet
    last = h.received['torque_servo/state'][-1]
    assert 'stale' in last.status and 'load_cell_1/force' in last.status
    assert h.received['valve_1/command'][-1].voltage == 0.0
    assert h.received['valve_2/command'][-1].voltage == 0.0
    feed(h, 0.5, setpoint=2.0)                  # fresh data: still vented, the fault latched
    last = h.received['torque_servo/state'][-1]
    assert 'latched' in last.status and h.received['valve_1/command'][-1].voltage == 0.0
    client = h.tester.create_client(Trigger, 'torque_servo/reset')
    h.spin_until(client.service_is_ready)
    done = client.call_async(Trigger.Request())
    h.spin_until(done.done)
    assert done.result().success
    feed_until(h, lambda: running(h), setpoint=2.0)              # reset: control resumes


@pytest.mark.wallclock
@pytest.mark.parametrize('joint', [JointState(), JointState(name=['motor'], position=[0.1]),
                                   JointState(name=['pulley'], position=[]),
                                   JointState(name=['pulley'], position=[float('nan')])])
def test_a_bad_joint_state_is_rejected_not_a_crash(harness: Harness, joint: JointState) -> None:
    """Empty, another joint, no position, NaN: rejected and counted, the valves vented; the
    node lives on and controls again once the joint comes back (read by name: a driver may
    publish several joints, in any order)."""
    h = harness
    feed_until(h, lambda: running(h), setpoint=2.0)
    for _ in range(20):
        h.send('encoder/joint_state', joint, h.tester.get_clock().now().nanoseconds)
        h.executor.spin_once(timeout_sec=0.002)
    h.spin_until(lambda: h.node.rejected_count > 0)
    several = JointState(name=['motor', 'pulley'], position=[5.0, 0.0])
    h.send('encoder/joint_state', several, h.tester.get_clock().now().nanoseconds)
    h.spin_until(lambda: h.node.angle_rad == 0.0)
    from diagnostic_msgs.msg import DiagnosticStatus
    h.spin_until(lambda: any(s.name.endswith(': inputs') and s.level == DiagnosticStatus.ERROR
                             for d in h.diagnostics for s in d.status))
