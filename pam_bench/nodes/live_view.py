"""live_view: serves the bench's topics to Foxglove while a run goes on (``live.server``).

A thin node: every topic of ``topics`` is subscribed raw (CDR bytes, as the recorder takes
them) and its bytes go to the Foxglove server stamped with the message's header stamp, through
the topic's rate cap. Topics sent whole (``full_rate_topics``) are subscribed reliable, as
their publishers are; the capped 1 kHz topics best effort, which matches any publisher and
never holds it back. The server binds ``host`` (127.0.0.1 unless told otherwise). Started by
``pam-bench run ... --live [PORT]`` beside the run, and by ``pam-bench live [SCENE]`` to join
a running graph.
"""

from __future__ import annotations

import functools
import os
from typing import Any

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from pam_bench.config.settings import LiveViewSettings
from pam_bench.config.topics import in_namespace
from pam_bench.live.server import LiveServer
from pam_bench.runtime.core import Spin
from pam_bench.runtime.messages import message_class, stamp_of_cdr
from pam_bench.runtime.params import declare_settings

__all__ = ['LiveView', 'main', 'READY']

READY = 'live view: serving'
"""Start of the line the node prints once its server is up (the bring-up waits for it)."""


class LiveView(Node):
    """The live view node (module docstring)."""

    GRACEFUL_STOP = True      # Ctrl-C ends the loop between two messages

    def spin_mode(self) -> Spin:
        """Its own loop over its subscriptions (``runtime.process.lean_spin``)."""
        return Spin.LEAN

    def __init__(self, name: str = 'live_view', **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        s: LiveViewSettings = declare_settings(self, LiveViewSettings)
        self.settings = s
        if s.niceness:
            os.nice(s.niceness)     # the view yields the CPU to the nodes that measure
        self.server = LiveServer(s.host, s.port, s.max_rate_hz, s.full_rate_topics)
        full = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                          history=HistoryPolicy.KEEP_LAST, durability=DurabilityPolicy.VOLATILE)
        capped = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT,
                            history=HistoryPolicy.KEEP_LAST, durability=DurabilityPolicy.VOLATILE)
        for entry in (e for e in s.topics if e):
            topic, _, msgtype = entry.partition(':')
            self.server.add_topic(topic, msgtype)       # shown by its name in the contract,
            self.create_subscription(message_class(msgtype),   # taken from its bench (__ns)
                                     in_namespace(topic, self.get_namespace()),
                                     functools.partial(self._on, topic),
                                     full if topic in self.server.full_rate_topics else capped,
                                     raw=True)
        print(f'{READY} {len(self.server.channels)} topics on {self.server.url} (open it in '
              'Foxglove: Open connection, Foxglove WebSocket)', flush=True)

    def _on(self, topic: str, data: bytes) -> None:
        try:        # the cap first: most 1 kHz messages go no further (no copy, no stamp read)
            if self.server.admit(topic):
                self.server.send(topic, bytes(data), stamp_of_cdr(data))
        except Exception as exc:  # noqa: BLE001 - a callback never lets an exception out
            self.get_logger().warning(f'live view: {topic}: {exc}')

    def destroy_node(self) -> None:
        """Stop the server with the node."""
        self.server.stop()
        super().destroy_node()


def main(args: list[str] | None = None) -> None:
    """Run the node until Ctrl-C or SIGTERM; a port in use is one line and exit code 2
    (``runtime.process.run_node``)."""
    from pam_bench.runtime.process import run_node
    run_node(LiveView, args)


if __name__ == '__main__':
    main()
