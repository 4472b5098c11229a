"""The QoS profiles of the bench's topics, one per use (lock-step, driver, sensor reader)."""

from __future__ import annotations

from typing import Any

from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_sensor_data,
)

__all__ = ['RELIABLE', 'LATCHED', 'LOCKSTEP', 'DRIVER', 'SENSOR', 'bag_qos', 'lockstep_offer']

RELIABLE = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                      history=HistoryPolicy.KEEP_LAST, durability=DurabilityPolicy.VOLATILE)
"""Events, commands, acknowledgements: reliable, the last 100."""
LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     history=HistoryPolicy.KEEP_LAST, durability=DurabilityPolicy.TRANSIENT_LOCAL)
"""A state a tool that joins late must still get (``protocol/status``): reliable, transient
local, the last one (as ``/tf_static`` and ``/robot_description``)."""
LOCKSTEP = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                      history=HistoryPolicy.KEEP_ALL, durability=DurabilityPolicy.VOLATILE)
"""Lock-step inputs and outputs keep everything: a 1 kHz record puts 1000 load-cell samples on
the wire in one exchange, and a bounded history would drop the oldest before the readers take
them (a reader on a wall clock wants the latest instead: RELIABLE)."""
DRIVER = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                    history=HistoryPolicy.KEEP_LAST, durability=DurabilityPolicy.VOLATILE)
"""On a wall clock, as REP-2003 asks of sensor drivers: publish reliable (any subscriber can
match, a recorder gets every message) with a history of 1 s at 1 kHz, volatile (with 100 ms, a
sample the middleware dropped on its way to a busy recorder was sometimes overwritten before
the recorder asked for it again: a gap in 1 of about 6 wall-clock runs)."""
SENSOR = QoSProfile(depth=100, reliability=qos_profile_sensor_data.reliability,
                    history=HistoryPolicy.KEEP_LAST, durability=DurabilityPolicy.VOLATILE)
"""Consumers that want the latest reading subscribe best effort (the sensor-data profile,
deeper: 100)."""


def _duration(d: Any) -> Any:
    from rosbags.interfaces import QosTime
    ns = int(d.nanoseconds)
    return QosTime(ns // 1_000_000_000, ns % 1_000_000_000)


def bag_qos(profile: QoSProfile) -> Any:
    """A QoS profile as a bag stores it among a connection's ``offered_qos_profiles`` (the
    rosbags ``Qos``, which rosbag2 writes into metadata.yaml and the MCAP channel): what a
    player needs to offer a topic as it was offered, a latched one transient local. The policy
    numbers are rmw's, the same in rclpy and rosbags."""
    from rosbags.interfaces import (
        Qos,
        QosDurability,
        QosHistory,
        QosLiveliness,
        QosReliability,
    )
    return Qos(QosHistory(int(profile.history)), int(profile.depth),
               QosReliability(int(profile.reliability)), QosDurability(int(profile.durability)),
               _duration(profile.deadline), _duration(profile.lifespan),
               QosLiveliness(int(profile.liveliness)),
               _duration(profile.liveliness_lease_duration),
               bool(profile.avoid_ros_namespace_conventions))


def lockstep_offer(topic: str, step: bool) -> QoSProfile:
    """The profile a bench node offers ``topic`` (absolute name) with in lock-step: a step
    topic ``LOCKSTEP``, the protocol status ``LATCHED``, any other event ``RELIABLE``."""
    from pam_bench.config.topics import STATUS, absolute
    if step:
        return LOCKSTEP
    return LATCHED if topic == absolute(STATUS) else RELIABLE
