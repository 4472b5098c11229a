"""Every test that touches DDS runs on loopback in a domain of its own."""

from __future__ import annotations

import itertools
import os

import pytest

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')
# The domain IDs safe on Linux (ROS 2 docs: 0..101 and 215..232), each used once per session
# in order: a process some earlier test left behind (an emulator still publishing for a
# moment) can never be in the domain of a later test. Only past 119 domains does it wrap.
_SAFE = [*range(1, 102), *range(215, 233)]
_DOMAINS = itertools.count()


def next_domain() -> int:
    """A ROS_DOMAIN_ID no earlier test of this session used (module comment)."""
    return _SAFE[next(_DOMAINS) % len(_SAFE)]


@pytest.fixture
def ros_domain(monkeypatch: pytest.MonkeyPatch) -> int:
    """A fresh ROS_DOMAIN_ID for this test, exported to child processes."""
    domain = next_domain()
    monkeypatch.setenv('ROS_DOMAIN_ID', str(domain))
    monkeypatch.setenv('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    return domain
