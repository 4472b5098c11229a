"""Every test that touches DDS runs on loopback in a domain of its own."""

from __future__ import annotations

import itertools
import os

import pytest

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')
_DOMAINS = itertools.count(1 + (os.getpid() % 40) * 2)


def next_domain() -> int:
    """A ROS_DOMAIN_ID (1..100) no other test of this session uses."""
    return 1 + next(_DOMAINS) % 100


@pytest.fixture
def ros_domain(monkeypatch: pytest.MonkeyPatch) -> int:
    """A fresh ROS_DOMAIN_ID for this test, exported to child processes."""
    domain = next_domain()
    monkeypatch.setenv('ROS_DOMAIN_ID', str(domain))
    monkeypatch.setenv('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    return domain
