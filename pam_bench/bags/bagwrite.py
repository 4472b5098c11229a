"""Write characteristic points and step records into a rosbag2 MCAP bag (rosbags only):
synthetic bags for tests and benchmarks."""

from __future__ import annotations

import pathlib

from rosbags.rosbag2 import StoragePlugin, Writer

from pam_bench.bags.types import bench_typestore
from pam_bench.config import topics

__all__ = ['write_bag']

POINT = 'pam_bench_interfaces/msg/CharacteristicPoint'
RECORD = 'pam_bench_interfaces/msg/StepResponseRecord'


def write_bag(path: pathlib.Path, points: list[dict], records: list[dict] | None = None
              ) -> None:
    """points: dicts of CharacteristicPoint fields (SI); records: StepResponseRecord fields."""
    store = bench_typestore()
    P = store.types[POINT]
    R = store.types[RECORD]
    Header = store.types['std_msgs/msg/Header']
    Time = store.types['builtin_interfaces/msg/Time']
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        cp = w.add_connection(topics.absolute(topics.POINT), POINT, typestore=store)
        cr = w.add_connection(topics.absolute(topics.RECORD), RECORD, typestore=store)
        for i, pt in enumerate(points):
            t = (i + 1) * 3_000_000_000
            hdr = Header(stamp=Time(sec=t // 10**9, nanosec=t % 10**9), frame_id='')
            msg = P(header=hdr, **pt)
            w.write(cp, t, store.serialize_cdr(msg, POINT))
        for i, rec in enumerate(records or []):
            t = (len(points) + i + 1) * 3_000_000_000
            hdr = Header(stamp=Time(sec=t // 10**9, nanosec=t % 10**9), frame_id='')
            w.write(cr, t, store.serialize_cdr(R(header=hdr, **rec), RECORD))
