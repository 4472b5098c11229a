"""driver_probe: joins a running graph and listens to the measured topics of the driver
contract (``config.drivers``) for a while, for ``pam-bench check-drivers``.

Per topic it records the publishers' types and reliability and, per message, the receive time,
the header stamp and the contract's value; ``config.drivers.judge`` says pass or fail. It also
looks whether each command topic of the controllers has a subscriber (a driver that listens).
It subscribes with the sensor-data profile (best effort), as the controllers do, so it matches
any publisher.
"""

from __future__ import annotations

import dataclasses
import functools
import time
from typing import Any

import rclpy
from geometry_msgs.msg import WrenchStamped
from rclpy.node import Node
from rclpy.qos import ReliabilityPolicy
from sensor_msgs.msg import FluidPressure, JointState

from pam_bench.config.drivers import COMMANDS, ENCODER, Seen, Verdict, contract, judge
from pam_bench.config.topics import in_namespace
from pam_bench.runtime.base import SENSOR
from pam_bench.runtime.messages import ns_of
from pam_bench.runtime.process import deadline_spin

__all__ = ['probe_drivers']

_CLASSES = {'sensor_msgs/msg/FluidPressure': FluidPressure,
            'geometry_msgs/msg/WrenchStamped': WrenchStamped,
            'sensor_msgs/msg/JointState': JointState}


def _value(msg: Any, joint: str) -> float:
    if isinstance(msg, FluidPressure):
        return float(msg.fluid_pressure)
    if isinstance(msg, WrenchStamped):
        return float(msg.wrench.force.x)
    names = list(msg.name)
    if joint not in names or names.index(joint) >= len(msg.position):
        return float('nan')
    return float(msg.position[names.index(joint)])


def probe_drivers(controllers: list[str], duration_s: float, settle_s: float = 5.0,
                  namespace: str = '', joint_name: str = 'pulley',
                  only: list[str] | None = None) -> list[Verdict]:
    """Listen ``duration_s`` (after up to ``settle_s`` of discovery and of waiting for a first
    message on every topic) and judge every topic of the bench in ``namespace`` ('': the
    root), the encoder's joint ``joint_name``; with ``only`` (absolute topic names of the
    contract), those topics alone.

    Returns one ``Verdict`` per measured topic, then (without ``only``) one per command topic
    (a subscriber present or not)."""
    rclpy.init()
    node = Node('pam_bench_check_drivers')
    expects = [dataclasses.replace(e, topic=in_namespace(e.topic, namespace))
               for e in contract(controllers) if only is None or e.topic in only]

    seen: dict[str, Seen] = {}
    flowing: list[Seen] = []              # the topics subscribed to
    try:
        end = time.monotonic() + settle_s        # discovery: wait until every topic is seen
        while time.monotonic() < end:
            names = dict(node.get_topic_names_and_types())
            if all(e.topic in names for e in expects):
                break
            rclpy.spin_once(node, timeout_sec=0.1)
        names = dict(node.get_topic_names_and_types())
        for e in expects:
            infos = node.get_publishers_info_by_topic(e.topic)
            s = Seen(sorted({i.topic_type for i in infos}),     # publishers', not readers
                     [i.qos_profile.reliability == ReliabilityPolicy.RELIABLE for i in infos],
                     [], [], [], duration_s)
            seen[e.topic] = s
            if e.msgtype in s.types:
                joint = joint_name if e.joint == ENCODER.joint else e.joint
                node.create_subscription(_CLASSES[e.msgtype], e.topic,
                                         functools.partial(_take, s, joint), SENSOR)
                flowing.append(s)
        # the window opens once every subscribed topic has delivered (a loaded machine may
        # take a while to match), within what is left of ``settle_s``; nothing before counts
        deadline_spin([node], lambda: None, 0.05, should_stop=lambda: time.monotonic() > end
                      or all(s.recv_ns for s in flowing))
        for s in seen.values():
            s.recv_ns.clear()
            s.stamp_ns.clear()
            s.values.clear()
            s.frame_ids.clear()
        end = time.monotonic() + duration_s      # one wait set: keeps up with 1 kHz topics
        deadline_spin([node], lambda: None, 0.05, should_stop=lambda: time.monotonic() > end)
        verdicts = [judge(e, seen[e.topic]) for e in expects]
        for name in controllers if only is None else []:
            for topic in (in_namespace(t, namespace) for t in COMMANDS.get(name, [])):
                n = node.count_subscribers(topic)
                verdicts.append(Verdict(topic, 'a driver subscribed', f'{n} subscriber(s)',
                                        n > 0, '' if n else 'no driver listens to the command'))
        return verdicts
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


def _take(s: Seen, joint: str, msg: Any) -> None:
    s.recv_ns.append(time.time_ns())
    s.stamp_ns.append(ns_of(msg.header.stamp))
    s.values.append(_value(msg, joint))
    s.frame_ids.add(msg.header.frame_id)
