"""Drive one node in lock-step from a test: publish /clock ticks and stamped inputs."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from pam_bench_interfaces.msg import StepAck
from rclpy.executors import SingleThreadedExecutor
from rosgraph_msgs.msg import Clock

from pam_bench.runtime.base import RELIABLE
from pam_bench.runtime.messages import ns_of, time_of


class Harness:
    """A test node plus the node under test in one fresh context and executor."""

    def __init__(self, make_node: Callable[[rclpy.Context], Any]) -> None:
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.node = None
        self.tester = rclpy.create_node('tester', context=self.context)
        self._clock_pub: Any = None        # made at the first tick: a clock under test
        self.acks: list[int] = []
        self.diagnostics: list[DiagnosticArray] = []
        self.received: dict[str, list[Any]] = {}
        self.pubs: dict[str, Any] = {}
        self.tester.create_subscription(StepAck, '/sim/ack',
                                        lambda m: self.acks.append(ns_of(m.header.stamp)),
                                        RELIABLE)
        self.tester.create_subscription(DiagnosticArray, '/diagnostics',
                                        self.diagnostics.append, RELIABLE)
        self.executor.add_node(self.tester)
        self.make_node = make_node

    def publisher(self, msg_type: type, topic: str) -> None:
        self.pubs[topic] = self.tester.create_publisher(msg_type, topic, RELIABLE)

    def listen(self, msg_type: type, topic: str) -> None:
        self.received[topic] = []
        self.tester.create_subscription(msg_type, topic, self.received[topic].append, RELIABLE)

    def add_node(self) -> None:
        """Create the node under test and spin it with the tester (wall clock: no tick)."""
        self.node = self.make_node(self.context)
        self.executor.add_node(self.node)

    def start(self) -> None:
        self.add_node()
        self.tick(0)

    def send(self, topic: str, msg: Any, t_ns: int) -> None:
        msg.header.stamp = time_of(t_ns)
        self.pubs[topic].publish(msg)

    def spin_until(self, cond: Callable[[], bool], timeout_s: float = 10.0) -> None:
        deadline = time.monotonic() + timeout_s
        while not cond():
            if time.monotonic() > deadline:
                raise TimeoutError('condition not met in time')
            self.executor.spin_once(timeout_sec=0.02)

    @property
    def clock_pub(self) -> Any:
        """The tester's /clock publisher, made at its first use: a sim clock under test sees
        no other /clock publisher otherwise (it stops a run that does)."""
        if self._clock_pub is None:
            self._clock_pub = self.tester.create_publisher(Clock, '/clock', RELIABLE)
        return self._clock_pub

    def tick(self, t_ns: int) -> None:
        """Publish /clock t (repeated while unacknowledged) and wait for the node's ack."""
        deadline = time.monotonic() + 10.0
        while t_ns not in self.acks:
            self.clock_pub.publish(Clock(clock=time_of(t_ns)))
            end = time.monotonic() + 0.1
            while t_ns not in self.acks and time.monotonic() < end:
                self.executor.spin_once(timeout_sec=0.01)
            if time.monotonic() > deadline:
                raise TimeoutError(f'no ack for {t_ns} ns')

    def close(self) -> None:
        if self.node is not None:
            self.executor.remove_node(self.node)
            self.node.destroy_node()
        self.executor.remove_node(self.tester)
        self.tester.destroy_node()
        self.executor.shutdown()
        rclpy.try_shutdown(context=self.context)
