"""The bench across two hosts: the simulated devices in one network namespace, the sequencer,
the clock and the recorder in another, joined by a veth pair and nothing else.

The test makes both namespaces itself (root or CAP_NET_ADMIN; skipped, with the reason, where
the machine refuses) and removes them. DDS discovers over the pair's subnet
(ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET, multicast routed onto the veth only); neither namespace
has any other interface or a default route, so nothing can leave the pair. The lock-step bag
must equal the one-host bag message for message.
"""

from __future__ import annotations

import os
import pathlib
import subprocess

import pytest

from pam_bench.bringup.runner import run_scene
from pam_bench.config.scene import load_scene
from pam_bench.vocabulary.run import RunOptions
from test.helpers import canonical_payloads


def _ip(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(['ip', *args], capture_output=True, text=True)


@pytest.fixture
def two_hosts():
    tag = f'{os.getpid() % 10000}'
    a, b = f'pbdev{tag}', f'pbctl{tag}'
    va, vb = f'pbv{tag}a', f'pbv{tag}b'
    net = 10 + os.getpid() % 200
    made = _ip('netns', 'add', a)
    if made.returncode != 0:
        reason = f'network namespaces not permitted here: {made.stderr.strip()}'
        print(reason)
        pytest.skip(reason)
    try:
        _ip('netns', 'add', b)
        for cmd in (('link', 'add', va, 'type', 'veth', 'peer', 'name', vb),
                    ('link', 'set', va, 'netns', a), ('link', 'set', vb, 'netns', b),
                    ('-n', a, 'addr', 'add', f'10.231.{net}.1/24', 'dev', va),
                    ('-n', b, 'addr', 'add', f'10.231.{net}.2/24', 'dev', vb),
                    ('-n', a, 'link', 'set', 'lo', 'up'), ('-n', b, 'link', 'set', 'lo', 'up'),
                    ('-n', a, 'link', 'set', va, 'up'), ('-n', b, 'link', 'set', vb, 'up'),
                    ('-n', a, 'route', 'add', '224.0.0.0/4', 'dev', va),
                    ('-n', b, 'route', 'add', '224.0.0.0/4', 'dev', vb)):
            res = _ip(*cmd)
            assert res.returncode == 0, (cmd, res.stderr)
        yield a, b, va, vb
    finally:
        _ip('netns', 'del', a)
        _ip('netns', 'del', b)


def _counters(ns: str, dev: str) -> tuple[int, int]:
    """(rx packets, tx packets) of ``dev`` in ``ns``."""
    base = f'/sys/class/net/{dev}/statistics'
    out = subprocess.run(['ip', 'netns', 'exec', ns, 'cat', f'{base}/rx_packets',
                          f'{base}/tx_packets'], capture_output=True, text=True).stdout.split()
    return int(out[0]), int(out[1])


def test_the_bench_across_two_namespaces_records_the_one_host_bag(
        tmp_path: pathlib.Path, ros_domain: int, two_hosts: tuple[str, str, str, str]) -> None:
    a, b, va, vb = two_hosts
    scene = load_scene('demo')
    here = run_scene(scene, str(tmp_path / 'one_host'), RunOptions(quiet=True))
    assert here.code == 0
    before = _counters(a, va)
    split = run_scene(scene, str(tmp_path / 'two_hosts'), RunOptions(quiet=True, netns=(a, b)))
    assert split.code == 0, split.summary
    after = _counters(a, va)
    assert after[0] - before[0] > 1000 and after[1] - before[1] > 1000   # it went over the pair
    assert canonical_payloads(tmp_path / 'two_hosts') == canonical_payloads(tmp_path / 'one_host')
    for ns, dev in ((a, va), (b, vb)):                     # nowhere else to go
        links = _ip('-n', ns, '-o', 'link').stdout
        names = sorted(line.split(':')[1].strip().split('@')[0] for line in links.splitlines())
        assert names == sorted(['lo', dev])
        assert 'default' not in _ip('-n', ns, 'route').stdout
