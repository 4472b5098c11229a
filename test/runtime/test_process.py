"""The spin loops of a node's process (``runtime.process``)."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest
import rclpy
from std_msgs.msg import Float64

from pam_bench.runtime.base import RELIABLE
from pam_bench.runtime.process import deadline_spin


def test_a_tick_longer_than_its_period_still_lets_the_messages_in(
        context: rclpy.Context, context_with: Any, own: Any) -> None:
    """A driver whose bus round trip outlasts its period (a Modbus request on a loaded
    machine) ticks as fast as it can and still takes every command soon after it is sent; the
    loop once ticked back to back and the commands came in bursts seconds apart."""
    node = own(rclpy.create_node('driver', context=context))
    got: list[tuple[float, float]] = []           # (sent, received) monotonic s
    node.create_subscription(Float64, 'command', lambda m: got.append((m.data,
                                                                        time.monotonic())),
                             RELIABLE)
    sender = own(rclpy.create_node('sender', context=context_with([])))
    pub = sender.create_publisher(Float64, 'command', RELIABLE)
    ticks: list[float] = []
    end = time.monotonic() + 1.5

    def tick() -> None:                 # 3 ms of work for a 1 ms period
        ticks.append(time.monotonic())
        time.sleep(0.003)

    def send() -> None:
        while pub.get_subscription_count() == 0 and time.monotonic() < end:
            time.sleep(0.01)
        while time.monotonic() < end - 0.3:
            pub.publish(Float64(data=time.monotonic()))
            time.sleep(0.002)
    thread = threading.Thread(target=send)
    thread.start()
    try:
        deadline_spin([node], tick, 0.001, should_stop=lambda: time.monotonic() > end)
    finally:
        thread.join()
    assert len(got) > 100, len(got)
    # from the first arrival on: before it, the reader may still be matching the writer (the
    # writer saw the reader first; beside two busy loops its first messages waited 0.43 s)
    first = min(received for _, received in got)
    delays = [received - sent for sent, received in got if sent >= first]
    assert len(delays) > 100, len(delays)
    assert max(delays) < 0.25, max(delays)         # taken between ticks, never in bursts
    assert len(ticks) > 50                          # and it still ticks as fast as it can


def test_a_loop_that_stalled_while_it_waited_serves_the_messages_before_its_tick(
        context: rclpy.Context, context_with: Any, own: Any) -> None:
    """A process stalled outside its tick (here a poll of 0.2 s, on a loaded machine the
    scheduler) serves what came meanwhile before it ticks: a sequencer that ticked first judged
    its inputs 0.2 s old although fresh ones sat in its queue."""
    node = own(rclpy.create_node('sequencer', context=context))
    last: list[float] = [0.0]
    node.create_subscription(Float64, 'state', lambda m: last.__setitem__(0, m.data), RELIABLE)
    sender = own(rclpy.create_node('device', context=context_with([])))
    pub = sender.create_publisher(Float64, 'state', RELIABLE)
    end = time.monotonic() + 1.5
    stall: list[float] = []
    seen: list[tuple[float, float]] = []            # (tick at, newest message sent at)

    def poll() -> None:
        if not stall and time.monotonic() > end - 0.8 and last[0] > 0.0:
            time.sleep(0.2)
            stall.append(time.monotonic())

    def send() -> None:
        while time.monotonic() < end:
            pub.publish(Float64(data=time.monotonic()))
            time.sleep(0.002)
    thread = threading.Thread(target=send)
    thread.start()
    try:
        deadline_spin([node], lambda: seen.append((time.monotonic(), last[0])), 0.01,
                      poll=poll, poll_period_s=0.005,
                      should_stop=lambda: time.monotonic() > end)
    finally:
        thread.join()
    assert stall, 'the messages never came'
    at, newest = next((t, s) for t, s in seen if t >= stall[0])
    assert at - newest < 0.05, (at - newest)        # not the 0.2 s of the stall


@contextlib.contextmanager
def _lockstep_node(ros_domain: int) -> Iterator[subprocess.Popen]:
    """A device node in a process of its own, waiting for a /clock that never comes (killed
    on the way out if it is still there)."""
    env = {**os.environ, 'ROS_DOMAIN_ID': str(ros_domain)}
    proc = subprocess.Popen([sys.executable, '-m', 'pam_bench.nodes.valve_sim', '--ros-args',
                             '-r', '__node:=valve_1'], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    try:
        yield proc
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()


@pytest.mark.parametrize('delay_s', [0.0, 0.1, 0.25, 0.4, 0.6])
def test_a_node_interrupted_while_it_waits_ends_cleanly(ros_domain: int,
                                                        delay_s: float) -> None:
    """Ctrl-C to a node spinning in its lean loop: exit 0, no crash. The loop's signal guard
    condition was destroyed as the loop left, while rclpy's signal thread could still trigger
    it: SIGSEGV in about half of the tries (``runtime.process.interrupt_guard``)."""
    with _lockstep_node(ros_domain) as proc:
        assert proc.stdout is not None
        for line in proc.stdout:
            if 'waiting for /clock' in line:
                break
        time.sleep(delay_s)
        proc.send_signal(signal.SIGINT)
        out = proc.communicate(timeout=20)[0]
    assert proc.returncode == 0, out[-3000:]
    assert 'Fatal Python error' not in out and 'Traceback' not in out, out[-3000:]


@pytest.mark.parametrize('delay_s', [0.02, 0.15, 0.3, 0.6])
def test_a_node_stopped_by_sigterm_while_it_starts_says_nothing(ros_domain: int,
                                                                delay_s: float) -> None:
    """How a run stops its nodes (``bringup.common.stop_processes``), at any moment of their
    start: importing (SIGTERM's default action), in rclpy's start or spinning; never a
    traceback."""
    with _lockstep_node(ros_domain) as proc:
        time.sleep(delay_s)
        proc.send_signal(signal.SIGTERM)
        out = proc.communicate(timeout=20)[0]
    assert proc.returncode in (0, -signal.SIGTERM), out[-3000:]
    assert 'Traceback' not in out and 'Fatal Python error' not in out, out[-3000:]
