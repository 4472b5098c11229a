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
        assert emu.stdout is not None
        for line in emu.stdout:               # the devices are up (a loaded machine is slow)
            if 'running on the wall clock' in line:
                break
        rec = _start(['-m', 'pam_bench.cli', 'record', '--all', '--out', str(bag)])
        assert rec.stdout is not None
        first = rec.stdout.readline()         # its bag is open (a loaded machine starts slowly)
        time.sleep(4.0)
        out = first + _stop(rec, signal.SIGTERM)
    finally:
        devices = _stop(emu)
    assert rec.returncode == 0, out
    assert 'bag closed' in out and '/load_cell_1/force' in out
    lines = [ln for ln in out.splitlines() if ln.strip().startswith('/load_cell_1/force')]
    assert lines and '0 lost in between' in lines[0], out
    forces = bag_messages(bag, '/load_cell_1/force')
    # seconds of a 1 kHz topic (once in a CI run none came: what both processes said)
    assert len(forces) > 1000, out + '\n--- emulate:\n' + devices[-3000:]
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


SHORT = """description: two readings by hand
exchange_step_s: 1.5
protocol: isometric_quick
protocol_overrides: {x_m: [0.04, 0.04, 0.01], voltage_v: [0.0, 1.0, 1.0], dwell_s: 1.5}
nodes: [valve_1, muscle_1, load_cell_1, encoder, loading_servo, sequencer, recorder]
"""


@pytest.mark.parametrize('ending', ['done', 'aborted'])
def test_a_bag_recorded_node_by_node_says_how_the_protocol_ended(
        tmp_path: pathlib.Path, ros_domain: int, ending: str) -> None:
    """Issue 52: the README's node-by-node run (emulate, recorder and sequencer started by
    hand, no runner): info reads done, or aborted when the devices die mid-run, from the
    sequencer's own status in the bag, not 'interrupted'."""
    from pam_bench.bags.baginfo import bag_info
    scene = tmp_path / 'short.yaml'
    scene.write_text(SHORT)
    params = tmp_path / 'bench.yaml'
    bin_dir = pathlib.Path(sys.executable).parent
    subprocess.run([sys.executable, '-m', 'pam_bench.cli', 'params', str(scene), '--ros-yaml',
                    str(params)], check=True, timeout=60)
    bag = tmp_path / 'by_hand'
    emu = _start(['-m', 'pam_bench.cli', 'emulate', str(scene)])
    rec = subprocess.Popen([str(bin_dir / 'recorder'), '--ros-args', '--params-file',
                            str(params), '-p', f'out_dir:={bag}'], stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, text=True, start_new_session=True)
    seq = subprocess.Popen([str(bin_dir / 'sequencer'), '--ros-args', '--params-file',
                            str(params)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                           text=True, start_new_session=True)
    try:
        if ending == 'aborted':
            assert seq.stdout is not None
            for line in seq.stdout:                 # the first reading taken: the devices go
                if '1/4 readings' in line or '2/4 readings' in line:
                    break
            _stop(emu, signal.SIGKILL)
        seq_out = seq.communicate(timeout=90)[0]
    finally:
        _stop(seq)
        rec_out = _stop(rec)
        _stop(emu)
    assert seq.returncode == (0 if ending == 'done' else 4), seq_out
    end = bag_info(bag)['end']
    assert end['state'] == ending, (end, rec_out)
    assert end['reason'].startswith('protocol isometric_quick'), end
