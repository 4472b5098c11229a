"""Nodes started by hand: parameters that mean what they say (read-only structure, tunables taken
at a safe point, wildcard sections warned about, not refused) and a word about the clock."""

from __future__ import annotations

import pathlib
from typing import Any

import pytest
import rclpy
from rcl_interfaces.srv import SetParameters
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter

from pam_bench.nodes.sequencer import SequencerNode
from pam_bench.nodes.torque_servo import TorqueServoNode
from pam_bench.runtime.process import reject_undeclared
from pam_bench.vocabulary.errors import ParameterError

WALL = [Parameter('lockstep', value=False)]


def _servo(ctx: rclpy.Context, **values: Any) -> TorqueServoNode:
    return TorqueServoNode('torque_servo', context=ctx, parameter_overrides=[
        *WALL, Parameter('controller', value='pid'),
        *(Parameter(k, value=v) for k, v in values.items())])


@pytest.mark.parametrize('name, value', [
    ('muscles', 1), ('controller', 'static_inverse_pid'), ('lockstep', True),
    ('servo.pitch_diameter_m', 0.05), ('inverse_model_file', '/tmp/x.yaml'),
    ('joint_name', 'knee'),
])
def test_structural_parameters_are_read_only(context: rclpy.Context, own: Any, name: str,
                                             value: Any) -> None:
    node = own(_servo(context))
    before = node.get_parameter(name).value
    result = node.set_parameters([Parameter(name, value=value)])[0]
    assert not result.successful and 'read-only' in result.reason
    assert node.get_parameter(name).value == before
    assert node.describe_parameter(name).read_only


def test_servo_gains_and_set_point_change_at_the_next_step(context: rclpy.Context,
                                                           own: Any) -> None:
    node = own(_servo(context))
    pid = node.ctl.pids[0]
    pid.integral = 2.0                       # as after a while of control
    i_term = pid.ki * pid.integral
    result = node.set_parameters([Parameter('servo.kp_v_per_n', value=0.01),
                                  Parameter('servo.ki_v_per_n_s', value=0.4),
                                  Parameter('amplitude', value=3.0),
                                  Parameter('signal', value='square')])
    assert all(r.successful for r in result)
    assert pid.kp == 0.004 and node.signal.amplitude == 5.0       # not before the step
    node.apply_tuning()                                             # the safe point
    assert pid.kp == 0.01 and pid.ki == 0.4
    assert pid.ki * pid.integral == pytest.approx(i_term, rel=1e-12)   # bumpless
    assert node.signal.amplitude == 3.0 and node.signal.kind.value == 'square'
    assert node.settings.servo.kp_v_per_n == 0.01


@pytest.mark.parametrize('name, value, words', [
    ('servo.kp_v_per_n', 50.0, 'servo.kp_v_per_n'),      # out of its range [0, 10]
    ('signal', 'triangle', 'signal'),                   # not one of the choices
    ('stale_timeout_s', 0.0, 'stale_timeout_s'),
])
def test_a_bad_tunable_value_is_refused_with_a_reason(context: rclpy.Context, own: Any,
                                                      name: str, value: Any, words: str) -> None:
    node = own(_servo(context))
    before = node.get_parameter(name).value
    result = node.set_parameters([Parameter(name, value=value)])[0]
    assert not result.successful and words in result.reason
    node.apply_tuning()
    assert node.get_parameter(name).value == before


def test_sequencer_suspenders_and_periods(context: rclpy.Context, own: Any) -> None:
    node = own(SequencerNode('sequencer', context=context, parameter_overrides=[
        *WALL, Parameter('autostart', value=False)]))
    bad = node.set_parameters([Parameter('suspenders_yaml', value='[{input: speed}]')])[0]
    assert not bad.successful and 'speed' in bad.reason
    good = node.set_parameters([
        Parameter('suspenders_yaml', value='[{input: force, low: -10.0, high: 900.0}]'),
        Parameter('stale_timeout_s', value=2.0), Parameter('status_period_s', value=0.25),
        Parameter('diagnostics_period_s', value=0.5)])
    assert all(r.successful for r in good)
    node.apply_tuning()
    assert node.runner.settings.stale_timeout_s == 2.0
    assert node.runner.settings.status_period_s == 0.25
    assert node.runner.bands == {'force': (-10.0, 900.0)}
    assert node.diagnostics.period_ns == 500_000_000
    ro = node.set_parameters([Parameter('channel', value=2)])[0]
    assert not ro.successful and node.channel == 1


def test_a_change_through_the_parameter_service(context: rclpy.Context, own: Any) -> None:
    """As `ros2 param set` does it: the set_parameters service of a wall-clock node."""
    node = own(_servo(context))
    client_node = own(rclpy.create_node('tuner', context=context))
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    executor.add_node(client_node)
    try:
        client = client_node.create_client(SetParameters, '/torque_servo/set_parameters')
        assert client.wait_for_service(timeout_sec=10.0)
        request = SetParameters.Request(parameters=[
            Parameter('offset', value=1.5).to_parameter_msg(),
            Parameter('muscles', value=1).to_parameter_msg()])
        future = client.call_async(request)
        executor.spin_until_future_complete(future, timeout_sec=10.0)
        offset, muscles = future.result().results
        assert offset.successful and not muscles.successful
        node.apply_tuning()
        assert node.signal.offset == 1.5 and node.muscles == 2
    finally:
        executor.shutdown()


def _params_file(tmp_path: pathlib.Path, text: str) -> list[str]:
    path = tmp_path / 'params.yaml'
    path.write_text(text)
    return ['--ros-args', '--params-file', str(path)]


def test_a_wildcard_section_key_is_warned_about_not_refused(context_with: Any, own: Any,
                                                           tmp_path: pathlib.Path) -> None:
    args = _params_file(tmp_path, '/**:\n  ros__parameters:\n    rate_hz: 500.0\n'
                        '/**/sequencer:\n  ros__parameters:\n    lockstep: false\n'
                        '    autostart: false\n')
    node = own(SequencerNode('sequencer', context=context_with(args)))
    assert node.lockstep is False                 # its own /**/sequencer section applies
    reject_undeclared(node, args=args)            # rate_hz: a device's, ignored here


def test_a_misspelt_key_of_the_own_section_is_refused(context_with: Any, own: Any,
                                                     tmp_path: pathlib.Path) -> None:
    args = _params_file(tmp_path, '/**:\n  ros__parameters:\n    rate_hz: 500.0\n'
                        'sequencer:\n  ros__parameters:\n    lockstep: false\n'
                        '    autostart: false\n    stale_timout_s: 1.0\n')
    node = own(SequencerNode('sequencer', context=context_with(args)))
    with pytest.raises(ParameterError, match='stale_timout_s'):
        reject_undeclared(node, args=args)


def test_a_bare_node_says_once_that_it_waits_for_the_clock(ros_domain: int) -> None:
    import subprocess
    import sys
    proc = subprocess.Popen([sys.executable, '-m', 'pam_bench.nodes.valve_sim'],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
    finally:
        proc.kill()
        proc.wait()
    assert 'waiting for /clock' in line and 'lockstep:=false' in line, line
