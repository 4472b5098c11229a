"""Read characteristic points and step-response records from one or many rosbag2 bags.

Only ``rosbags`` is needed (no ROS install): the bench's own message types are registered
from the .msg text in msg_defs/. Every failure gives one ``BagError`` with a clear message:
a path that is not a bag, a truncated or corrupt file, a bag without the protocol topics.
"""

from __future__ import annotations

import dataclasses
import pathlib
from collections.abc import Iterable
from typing import Any

import numpy as np
from rosbags.rosbag2 import Reader

from pam_bench.bags.errors import BagError
from pam_bench.bags.types import bench_typestore
from pam_bench.config import topics

__all__ = ['Points', 'StepRecord', 'BagData', 'read_bags', 'open_bag',
           'topic_messages']

POINT_TOPIC = topics.absolute(topics.POINT)
RECORD_TOPIC = topics.absolute(topics.RECORD)




@dataclasses.dataclass
class Points:
    """Characteristic points of one protocol as columns (SI units), each of shape (n,)."""

    protocol: str
    t_s: np.ndarray
    series: np.ndarray
    step: np.ndarray
    direction: np.ndarray          # 0 up, 1 down
    series_value: np.ndarray
    set_value: np.ndarray
    voltage_v: np.ndarray
    force_n: np.ndarray
    contraction_m: np.ndarray
    pressure_pa: np.ndarray

    def __len__(self) -> int:
        return len(self.t_s)


@dataclasses.dataclass
class StepRecord:
    """One step response: held contraction (m), u0 -> u1 (V), force samples (N), period (s)."""

    series: int
    step: int
    direction: int
    contraction_m: float
    voltage_initial_v: float
    voltage_final_v: float
    sample_period_s: float
    force_n: np.ndarray


@dataclasses.dataclass
class BagData:
    """Everything extracted from the bags: points per protocol and the step records."""

    points: dict[str, Points]
    records: list[StepRecord]


def open_bag(path: pathlib.Path) -> Reader:
    """Open a rosbag2 folder or raise one clear ``BagError``."""
    if not path.exists():
        raise BagError(f'{path}: no such bag')
    if path.is_file():
        raise BagError(f'{path}: not a rosbag2 directory (expected a folder with '
                       'metadata.yaml and the .mcap file)')
    if not (path / 'metadata.yaml').exists():
        if any(path.glob('*.mcap')) or any(path.glob('.part_*/*.mcap')):
            from pam_bench.bags.splitwriter import bag_in_use
            if bag_in_use(path):
                raise BagError(f'{path}: being written (its recorder is running): read it '
                               'once the run has ended')
            raise BagError(f'{path}: never closed (its recorder was killed?): run '
                           f'pam-bench bag-repair {path}')
        raise BagError(f'{path}: no metadata.yaml, not a rosbag2 bag')
    try:
        reader = Reader(path)
        reader.open()
    except Exception as exc:  # noqa: BLE001 - rosbags raises several types
        raise BagError(f'{path}: cannot open the bag ({exc})') from None
    return reader


BENCH_TYPES = {POINT_TOPIC: 'pam_bench_interfaces/msg/CharacteristicPoint',
               RECORD_TOPIC: 'pam_bench_interfaces/msg/StepResponseRecord'}
"""The topics the analysis reads and the type each must hold."""


def _bench_connections(path: pathlib.Path, reader: Reader) -> list[Any]:
    """The connections of ``reader`` the analysis reads, checked to be pam_bench's.

    Raises:
        BagError: "not a pam_bench bag" and why: neither topic, or a topic holding another
            type (a bag of another recorder or another bench, read for what it holds).
    """
    store = bench_typestore()
    conns = []
    for c in reader.connections:
        want = next((t for topic, t in BENCH_TYPES.items() if topics.same_topic(c.topic, topic)),
                    None)
        if want is None:
            continue
        if c.msgtype != want:
            raise BagError(f'{path}: not a pam_bench bag: {c.topic} holds {c.msgtype}, not '
                           f'{want}')
        if c.msgdef.data and c.msgdef.data.strip() and c.digest and not c.digest.startswith(
                'RIHS01_000') and c.digest != store.hash_rihs01(want):
            raise BagError(f'{path}: not a pam_bench bag of these interfaces: {c.topic} holds '
                           f'a {want} of another definition (a bag of another pam_bench '
                           'version?)')
        conns.append(c)
    if not conns and reader.connections:
        held = ', '.join(sorted({c.topic for c in reader.connections})[:6])
        raise BagError(f'{path}: not a pam_bench bag: it has no {POINT_TOPIC} or '
                       f'{RECORD_TOPIC} (it holds {held}'
                       + (', ...' if len({c.topic for c in reader.connections}) > 6 else '')
                       + ')')
    return conns


def read_bags(paths: Iterable[str | pathlib.Path]) -> BagData:
    """Read the protocol points and step records of every bag.

    Raises:
        BagError: a bag is missing, not a bag, truncated, or none holds protocol points.
    """
    store = bench_typestore()
    rows: dict[str, list[tuple]] = {}
    records: list[StepRecord] = []
    bags = [pathlib.Path(p) for p in paths]
    if not bags:
        raise BagError('no bag given')
    for path in bags:
        reader = open_bag(path)
        try:
            conns = _bench_connections(path, reader)
            for conn, _, raw in reader.messages(connections=conns):
                msg: Any = store.deserialize_cdr(raw, conn.msgtype)
                if topics.same_topic(conn.topic, POINT_TOPIC):
                    t = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
                    rows.setdefault(msg.protocol, []).append(
                        (t, msg.series, msg.step, msg.direction, msg.series_value,
                         msg.set_value, msg.voltage, msg.force, msg.contraction, msg.pressure))
                else:
                    records.append(StepRecord(msg.series, msg.step, msg.direction,
                                              msg.contraction, msg.voltage_initial,
                                              msg.voltage_final, msg.sample_period,
                                              np.asarray(msg.force, dtype=float)))
        except BagError:
            raise
        except Exception as exc:  # noqa: BLE001 - truncated chunks, bad CDR, ...
            raise BagError(f'{path}: the bag is damaged or truncated ({exc})') from None
        finally:
            reader.close()
    if not rows and not records:
        raise BagError('no protocol points (topics /protocol/point, /protocol/step_response) in '
                       + ', '.join(str(p) for p in bags) + ': the run took no reading')
    points = {}
    for name, r in rows.items():
        a = np.array(sorted(r), dtype=float)
        points[name] = Points(name, a[:, 0], a[:, 1].astype(int), a[:, 2].astype(int),
                              a[:, 3].astype(int), a[:, 4], a[:, 5], a[:, 6], a[:, 7], a[:, 8],
                              a[:, 9])
    return BagData(points, records)


def topic_messages(path: str | pathlib.Path, topic: str) -> list[Any]:
    """Every message of ``topic`` in a bag (recorded in any namespace), decoded, in log-time
    order.

    Raises:
        BagError: the bag cannot be opened or read.
    """
    store = bench_typestore()
    reader = open_bag(pathlib.Path(path))
    try:
        conns = [c for c in reader.connections if topics.same_topic(c.topic, topic)]
        return [store.deserialize_cdr(raw, c.msgtype)
                for c, _, raw in reader.messages(connections=conns)]
    except Exception as exc:  # noqa: BLE001 - truncated chunks, bad CDR, ...
        raise BagError(f'{path}: the bag is damaged or truncated ({exc})') from None
    finally:
        reader.close()
