"""What every run's processes get in their environment (``bringup.common.ros_env``)."""

from __future__ import annotations

import os
import pathlib
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest

from pam_bench.bringup.common import ros_env
from pam_bench.config.dds import PROFILE_VARS
from pam_bench.config.paths import config_dir

NS = {'f': 'http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles'}


def test_the_discovery_profile_announces_every_half_second() -> None:
    path = config_dir() / 'fastdds' / 'discovery.xml'
    root = ET.parse(path).getroot()
    (participant,) = root.findall('f:participant', NS)
    assert participant.get('is_default_profile') == 'true'
    lease = participant.find('f:rtps/f:builtin/f:discovery_config/f:leaseAnnouncement', NS)
    assert lease is not None
    period = int(lease.findtext('f:sec', '0', NS)) + int(lease.findtext('f:nanosec', '0', NS)) \
        * 1e-9
    assert period == pytest.approx(0.5)
    # nothing else: the lease duration and the transports stay Fast DDS's and rmw's
    assert [e.tag.split('}')[1] for e in participant.iter()][1:] == [
        'rtps', 'builtin', 'discovery_config', 'leaseAnnouncement', 'sec', 'nanosec']


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
