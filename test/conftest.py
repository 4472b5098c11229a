"""Every test that touches DDS runs on loopback in a domain of its own, and finds the physics
core the one before it found; one demo bag per worker for the tests that read a bag."""

from __future__ import annotations

import itertools
import os
import pathlib
from collections.abc import Iterator
from typing import Any

import pytest

from pam_bench.models import jit

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')
# The domain IDs safe on Linux (ROS 2 docs: 0..101 and 215..232), each used once per session
# in order: a process some earlier test left behind (an emulator still publishing for a
# moment) can never be in the domain of a later test. Only past 119 domains does it wrap.
# Under pytest-xdist each worker takes every n-th of them (worker k of n: k, k + n, ...), so
# two workers never share a domain either. PAM_BENCH_TEST_DOMAIN_START moves the start: `make
# test` runs the wall-clock tests in a second session that starts where the first one's
# domains end (a default run uses about 70 domains in all).
_SAFE = [*range(1, 102), *range(215, 233)]
_WORKER = int(os.environ.get('PYTEST_XDIST_WORKER', 'gw0')[2:] or 0)
_WORKERS = int(os.environ.get('PYTEST_XDIST_WORKER_COUNT', '1'))
_START = int(os.environ.get('PAM_BENCH_TEST_DOMAIN_START', '0'))
_DOMAINS = itertools.count(_START + _WORKER, _WORKERS)


def next_domain() -> int:
    """A ROS_DOMAIN_ID no earlier test of this session used (module comment)."""
    return _SAFE[next(_DOMAINS) % len(_SAFE)]


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        'markers', 'wallclock: runs on the wall clock against deadlines (stale timeouts, '
        'rates, kill-to-vent latency); `make test` runs these alone, after the others')
    config.addinivalue_line(
        'markers', 'ros: starts ROS 2 nodes or processes (marked by where it lies and what it '
        'uses: ``ROS_FOLDERS``, ``ROS_FIXTURES``, ``ROS_WORDS``); `make check` leaves it out')
    config.addinivalue_line(
        'markers', 'slow: takes more than a few seconds without ROS (a fit, a sweep, a '
        'cluster); `make check` leaves it out')


ROS_FOLDERS = ('nodes', 'bringup', 'runtime', 'live', 'packaging', 'benchmarks', 'cluster')
"""Test folders whose every test starts nodes, processes or a cluster."""
ROS_FIXTURES = {'ros_domain', 'demo_bag'}
"""Fixtures that start ROS (a domain for nodes, a demo run)."""
ROS_WORDS = ('rclpy', "'run'", 'run_scene', '_pam_bench(', "'emulate'", 'engine: ros')
"""What a test module says when it starts ROS some other way."""
SLOW_WORDS = ('calibrate_bags', 'run_jobs', "'sweep'", 'connect(', 'LocalCluster',
              "'calibrate'", 'hypothesis')
"""What a test module says when it fits, sweeps or starts a cluster (slow without ROS)."""


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Mark every test ``ros`` or ``slow`` by its folder, fixtures and module text (the
    quick tier, ``make check``, runs the rest)."""
    texts: dict[pathlib.Path, str] = {}
    for item in items:
        path = pathlib.Path(str(item.fspath))
        if path not in texts:
            texts[path] = path.read_text(encoding='utf-8', errors='replace')
        text = texts[path]
        folder = path.parent.name
        if folder in ROS_FOLDERS or ROS_FIXTURES & set(getattr(item, 'fixturenames', ())) \
                or any(w in text for w in ROS_WORDS):
            item.add_marker(pytest.mark.ros)
        if any(w in text for w in SLOW_WORDS):
            item.add_marker(pytest.mark.slow)


@pytest.fixture
def ros_domain(monkeypatch: pytest.MonkeyPatch) -> int:
    """A fresh ROS_DOMAIN_ID for this test, exported to child processes."""
    domain = next_domain()
    monkeypatch.setenv('ROS_DOMAIN_ID', str(domain))
    monkeypatch.setenv('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    return domain


@pytest.fixture(autouse=True)
def core_restored() -> Iterator[None]:
    """The physics core this test found (``models.jit.core``) is the one the next test
    finds: a test that switches to the reference (``jit.use``, a node whose wall ticks
    pin it) does not leave the rest of its worker on it."""
    before = jit.core()
    yield
    if jit.core() != before:
        jit.use(before)


@pytest.fixture
def make_harness(ros_domain: int) -> Iterator[Any]:
    """``make_harness(make_node)``: a ``test.nodes.harness.Harness`` (a tester node beside the
    node ``make_node(context)`` in a fresh context), closed after the test."""
    from test.nodes.harness import Harness
    made: list[Harness] = []

    def make(make_node: Any) -> Harness:
        made.append(Harness(make_node))
        return made[-1]
    yield make
    for h in reversed(made):
        h.close()


@pytest.fixture(scope='session')
def demo_bag(tmp_path_factory: pytest.TempPathFactory) -> pathlib.Path:
    """A bag of the demo scene, recorded once; tests read it and never change it."""
    os.environ['ROS_DOMAIN_ID'] = str(next_domain())
    bag = tmp_path_factory.mktemp('demo') / 'demo_bag'
    from test.cli.helpers import cli
    code, out, err = cli('run', 'demo', '--out', bag)
    assert code == 0, out + err
    return bag
