"""recorder: writes the contract topics to a rosbag2 directory (metadata.yaml + .mcap).

Messages stay CDR bytes end to end (raw subscriptions, rosbags writer); the log time of each
message is its header stamp, i.e. sim time. Topics that are published at every step are
recorded in lock-step (the recorder acknowledges a step only once it holds all of them, so it
can never fall behind and lose data); event topics (points, status, diagnostics) as they come.
The bag is closed valid at the end of the scene and on SIGINT or SIGTERM.
"""

from __future__ import annotations

import pathlib
from typing import Any

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from rosbags.rosbag2 import StoragePlugin, Writer

from pam_bench.analysis.types import bench_typestore
from pam_bench.nodes.base import BenchNode, message_class, run_node, stamp_of_cdr

__all__ = ['Recorder', 'main']

KEEP_ALL = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                      history=HistoryPolicy.KEEP_ALL, durability=DurabilityPolicy.VOLATILE)


class Recorder(BenchNode):
    """Raw-bytes rosbag2 MCAP recorder."""

    def __init__(self, name: str = 'recorder', **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        out = self.declare_typed('out_dir', 'bags/run', 'bag directory to create')
        step_topics = self.declare_typed('step_topics', ['/clock:rosgraph_msgs/msg/Clock'],
                                         'topic:type recorded in lock-step (every step)')
        event_topics = self.declare_typed('event_topics', ['/diagnostics:diagnostic_msgs/msg/'
                                                           'DiagnosticArray'],
                                          'topic:type recorded as they come')
        self.store = bench_typestore()
        path = pathlib.Path(out)
        if path.exists():
            raise FileExistsError(f'bag directory {path} exists; remove it or pick another')
        path.parent.mkdir(parents=True, exist_ok=True)
        self.writer = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
        self.writer.open()
        self.count = 0
        self._clock_ns = -1
        self.connections = {}
        for entry in list(step_topics) + list(event_topics):
            topic, msgtype = self._split(entry)
            self.connections[topic] = self.writer.add_connection(topic, msgtype,
                                                                 typestore=self.store)
        for entry in step_topics:
            topic, msgtype = self._split(entry)
            if topic == '/clock':
                continue
            self.sync_input(message_class(msgtype), topic, self._writer_for(topic), raw=True)
        for entry in event_topics:
            topic, msgtype = self._split(entry)
            self.create_subscription(message_class(msgtype), topic, self._writer_for(topic),
                                     KEEP_ALL, raw=True)
        self.start_lockstep()

    @staticmethod
    def _split(entry: str) -> tuple[str, str]:
        topic, _, msgtype = entry.partition(':')
        if not msgtype:
            raise ValueError(f'recorder topic entry {entry!r} must be topic:package/msg/Type')
        return (topic if topic.startswith('/') else '/' + topic), msgtype

    def _writer_for(self, topic: str) -> Any:
        conn = self.connections[topic]

        def write(data: bytes) -> None:
            if self.writer is not None:
                self.writer.write(conn, stamp_of_cdr(data), bytes(data))
                self.count += 1
        return write

    def _on_clock(self, msg: Any) -> None:
        conn = self.connections.get('/clock')
        t = msg.clock.sec * 1_000_000_000 + msg.clock.nanosec
        if conn is not None and self.writer is not None and t > self._clock_ns:
            self._clock_ns = t
            self.writer.write(conn, t, serialize_message(msg))
            self.count += 1
        super()._on_clock(msg)

    def on_step(self, t_ns: int, dt_s: float, inputs: dict[str, Any]) -> None:
        """Everything was written on arrival; the step only acknowledges."""

    def close(self) -> None:
        """Close the bag (idempotent)."""
        if self.writer is not None:
            self.writer.close()
            self.writer = None
            self.get_logger().info(f'bag closed with {self.count} messages')

    def destroy_node(self) -> None:
        """Close the bag before the node goes."""
        self.close()
        super().destroy_node()


def main(args: list[str] | None = None) -> None:
    """Run the node."""
    run_node(Recorder, args)


if __name__ == '__main__':
    main()
