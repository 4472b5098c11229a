"""What every run's processes get in their environment and how they are stopped
(``bringup.common``)."""

from __future__ import annotations

import os
import pathlib
import signal
import subprocess
import sys
import xml.etree.ElementTree as ET
from typing import Any

import pytest

from pam_bench.bringup.common import ros_env
from pam_bench.config.dds import PROFILE_VARS
from pam_bench.config.paths import config_dir

NS = {'f': 'http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles'}


def _seconds(duration: ET.Element | None) -> float:
    """A Fast DDS duration element (sec, nanosec) in seconds."""
    assert duration is not None
    return int(duration.findtext('f:sec', '0', NS)) + int(duration.findtext('f:nanosec', '0',
                                                                              NS)) * 1e-9


def test_the_discovery_profile_announces_every_half_second() -> None:
    path = config_dir() / 'fastdds' / 'discovery.xml'
    root = ET.parse(path).getroot()
    (participant,) = root.findall('f:participant', NS)
    assert participant.get('is_default_profile') == 'true'
    lease = participant.find('f:rtps/f:builtin/f:discovery_config/f:leaseAnnouncement', NS)
    assert _seconds(lease) == pytest.approx(0.5)
    # nothing else: the lease duration and the transports stay Fast DDS's and rmw's
    assert [e.tag.split('}')[1] for e in participant.iter()][1:] == [
        'rtps', 'builtin', 'discovery_config', 'leaseAnnouncement', 'sec', 'nanosec']


def test_the_writers_heartbeat_every_tenth_of_a_second() -> None:
    """Every writer's default profile: a heartbeat every 0.1 s while a sample is not
    acknowledged, and nothing else of a writer changed (QoS stays what each node asks)."""
    root = ET.parse(config_dir() / 'fastdds' / 'discovery.xml').getroot()
    (writer,) = root.findall('f:data_writer', NS)
    assert writer.get('is_default_profile') == 'true'
    assert _seconds(writer.find('f:times/f:heartbeatPeriod', NS)) == pytest.approx(0.1)
    assert [e.tag.split('}')[1] for e in writer.iter()][1:] == [
        'times', 'heartbeatPeriod', 'sec', 'nanosec']
    assert [e.tag.split('}')[1] for e in root] == ['data_writer', 'participant']


@pytest.mark.parametrize('preset, expected', [
    ({}, 'bench'),
    ({'FASTRTPS_DEFAULT_PROFILES_FILE': '/lab/profile.xml'}, '/lab/profile.xml'),
    ({'FASTDDS_DEFAULT_PROFILES_FILE': '/lab/profile.xml'}, None),
    ({'RMW_IMPLEMENTATION': 'rmw_cyclonedds_cpp'}, None),
    ({'RMW_IMPLEMENTATION': 'rmw_fastrtps_cpp'}, 'bench'),
])
def test_a_run_names_its_profile_unless_the_lab_has_one(
        monkeypatch: pytest.MonkeyPatch, preset: dict[str, str], expected: str | None) -> None:
    for var in (*PROFILE_VARS, 'RMW_IMPLEMENTATION'):
        monkeypatch.delenv(var, raising=False)
    for var, value in preset.items():
        monkeypatch.setenv(var, value)
    env = ros_env(7)
    got = env.get(PROFILE_VARS[0])
    if expected == 'bench':
        assert got is not None and pathlib.Path(got) == config_dir() / 'fastdds' / 'discovery.xml'
    else:
        assert got == expected
    assert env['ROS_DOMAIN_ID'] == '7'


def test_the_command_s_own_process_names_it_too() -> None:
    """``pam-bench`` puts the profile in its own environment before any verb runs (a
    ``record`` or ``check-drivers`` beside a lab's driver announces often too)."""
    env = {k: v for k, v in os.environ.items() if k not in (*PROFILE_VARS, 'RMW_IMPLEMENTATION')}
    probe = ('import importlib, os\n'
             "m = importlib.import_module('pam_bench.cli.main')\n"
             "m.main = lambda: print(os.environ.get('FASTRTPS_DEFAULT_PROFILES_FILE')) or 0\n"
             'm.command()\n')
    out = subprocess.run([sys.executable, '-c', probe], env=env, capture_output=True,
                         text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert pathlib.Path(out.stdout.strip()) == config_dir() / 'fastdds' / 'discovery.xml'


def test_fast_dds_loads_the_profile_without_an_error(tmp_path: pathlib.Path,
                                                     ros_domain: int) -> None:
    """A node with a reliable publisher under the profile: Fast DDS parses it without a
    word (a profile it cannot parse is reported in its log and ignored; the control shows the
    check sees that)."""
    code = ('import rclpy\nfrom std_msgs.msg import Int64\n'
            'from rclpy.qos import QoSProfile, ReliabilityPolicy\n'
            'rclpy.init()\nn = rclpy.create_node("profile_probe")\n'
            'p = n.create_publisher(Int64, "probe", QoSProfile(depth=10, '
            'reliability=ReliabilityPolicy.RELIABLE))\np.publish(Int64())\nprint("ok")\n')
    good = config_dir() / 'fastdds' / 'discovery.xml'
    bad = tmp_path / 'bad.xml'
    bad.write_text(good.read_text().replace('<nanosec>100000000</nanosec>',
                                            '<nanosecs>100000000</nanosecs>'))
    errors = {}
    for name, path in (('good', good), ('bad', bad)):
        env = {k: v for k, v in os.environ.items() if k not in PROFILE_VARS}
        env[PROFILE_VARS[0]] = str(path)
        out = subprocess.run([sys.executable, '-c', code], env=env, capture_output=True,
                             text=True, timeout=30, check=False)
        assert out.returncode == 0 and 'ok' in out.stdout, out.stderr
        errors[name] = 'XMLPARSER' in out.stdout + out.stderr
    assert errors == {'good': False, 'bad': True}


class _Proc:
    """A node process as ``stop_processes`` sees it: it ends on the first signal it gets."""

    def __init__(self, name: str, log: list[tuple[str, int]]) -> None:
        self.name, self.log, self.returncode = name, log, None

    def poll(self) -> int | None:
        return self.returncode

    def send_signal(self, sig: int) -> None:
        self.log.append((self.name, sig))
        self.returncode = -sig

    def wait(self, timeout: float | None = None) -> int | None:
        return self.returncode


def test_nodes_are_stopped_by_sigterm_devices_first_recorder_last() -> None:
    """SIGTERM, not SIGINT (``bringup.common``'s docstring: a node still importing its modules
    would print a KeyboardInterrupt traceback), one each, the recorder after the others."""
    from pam_bench.bringup.common import stop_processes
    log: list[tuple[str, int]] = []
    procs: dict[str, Any] = {n: _Proc(n, log) for n in ('recorder', 'sim_clock', 'valve_1')}
    stop_processes(procs)
    assert log == [('sim_clock', signal.SIGTERM), ('valve_1', signal.SIGTERM),
                   ('recorder', signal.SIGTERM)]
