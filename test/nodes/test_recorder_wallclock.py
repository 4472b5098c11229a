"""`pam-bench record` on a running graph and the parameter services of wall-clock nodes."""

from __future__ import annotations

import os
import pathlib
import signal
import subprocess
import sys
import time

import pytest
import rclpy
from rcl_interfaces.srv import GetParameters

from test.helpers import bag_messages

pytestmark = pytest.mark.wallclock


def _start(args: list[str]) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, *args], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, start_new_session=True)


def _stop(proc: subprocess.Popen, sig: int = signal.SIGINT) -> str:
    if proc.poll() is None:
        os.killpg(proc.pid, sig)
    try:
        out, _ = proc.communicate(timeout=15)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, _ = proc.communicate()
    return out


def test_record_all_then_sigterm_leaves_a_valid_bag(tmp_path: pathlib.Path,
                                                    ros_domain: int) -> None:
    emu = _start(['-m', 'pam_bench.cli', 'emulate', 'demo'])
    bag = tmp_path / 'bag'
    try:
        time.sleep(2.0)
        rec = _start(['-m', 'pam_bench.cli', 'record', '--all', '--out', str(bag)])
        time.sleep(4.0)
        out = _stop(rec, signal.SIGTERM)
    finally:
        _stop(emu)
    assert rec.returncode == 0, out
    assert 'bag closed' in out and '/load_cell_1/force' in out
    lines = [ln for ln in out.splitlines() if ln.strip().startswith('/load_cell_1/force')]
    assert lines and '0 lost in between' in lines[0], out
    forces = bag_messages(bag, '/load_cell_1/force')
    assert len(forces) > 1000                       # seconds of a 1 kHz topic
    assert bag_messages(bag, '/valve_1/pressure')  # discovered, not named


def test_wallclock_nodes_answer_parameter_requests(ros_domain: int) -> None:
    servo = _start(['-m', 'pam_bench.nodes.torque_servo', '--ros-args', '-p', 'lockstep:=false',
                    '-p', 'controller:=pid', '-p', 'control_period_s:=0.002'])
    rclpy.init()
    node = rclpy.create_node('param_client')
    try:
        client = node.create_client(GetParameters, '/torque_servo/get_parameters')
        assert client.wait_for_service(timeout_sec=15.0), 'no parameter service'
        fut = client.call_async(GetParameters.Request(names=['control_period_s', 'lockstep']))
        rclpy.spin_until_future_complete(node, fut, timeout_sec=10.0)
        values = fut.result().values
        assert values[0].double_value == 0.002 and values[1].bool_value is False
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
        _stop(servo)
