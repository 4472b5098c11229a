"""The QoS profiles of the bench's topics, one per use (lock-step, driver, sensor reader)."""

from __future__ import annotations

from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_sensor_data,
)

__all__ = ['RELIABLE', 'LOCKSTEP', 'DRIVER', 'SENSOR']

RELIABLE = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                      history=HistoryPolicy.KEEP_LAST, durability=DurabilityPolicy.VOLATILE)
"""Events, commands, acknowledgements: reliable, the last 100."""
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
