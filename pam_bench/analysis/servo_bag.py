"""Read the torque servo's state (topic /torque_servo/state) from a bag: rosbags only."""

from __future__ import annotations

import pathlib
from typing import Any

import numpy as np

from pam_bench.bags.bagread import open_bag
from pam_bench.bags.errors import BagError
from pam_bench.bags.types import bench_typestore
from pam_bench.config import topics

__all__ = ['SERVO_TOPIC', 'read_servo_states']

SERVO_TOPIC = topics.absolute(topics.SERVO_STATE)


def read_servo_states(path: str | pathlib.Path) -> dict[str, np.ndarray]:
    """Columns of every TorqueServoState in the bag, sorted by stamp: t_s, torque_setpoint,
    torque_measured, angle (n,); force_setpoint, force_measured, u_feedforward, u_pid,
    voltage (n, 2); status (n,) strings.

    Raises:
        BagError: not a bag, damaged, or without servo states.
    """
    store = bench_typestore()
    reader = open_bag(pathlib.Path(path))
    rows = []
    try:
        conns = [c for c in reader.connections if topics.same_topic(c.topic, SERVO_TOPIC)]
        for conn, _, raw in reader.messages(connections=conns):
            m: Any = store.deserialize_cdr(raw, conn.msgtype)
            rows.append((m.header.stamp.sec + m.header.stamp.nanosec * 1e-9, m.torque_setpoint,
                         m.torque_measured, m.angle, list(m.force_setpoint),
                         list(m.force_measured), list(m.u_feedforward), list(m.u_pid),
                         list(m.voltage), m.status))
    except Exception as exc:  # noqa: BLE001 - truncated chunks, bad CDR, ...
        raise BagError(f'{path}: the bag is damaged or truncated ({exc})') from None
    finally:
        reader.close()
    if not rows:
        raise BagError(f'{path}: no torque servo states ({SERVO_TOPIC})')
    rows.sort(key=lambda r: r[0])
    keys = ('t_s', 'torque_setpoint', 'torque_measured', 'angle', 'force_setpoint',
            'force_measured', 'u_feedforward', 'u_pid', 'voltage', 'status')
    return {k: np.array([r[i] for r in rows]) for i, k in enumerate(keys)}
