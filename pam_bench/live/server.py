"""A Foxglove WebSocket server for the bench's topics, with a rate cap per topic.

``foxglove-sdk``'s server speaks Foxglove's WebSocket protocol (subprotocol
``foxglove.sdk.v1``, and ``foxglove.websocket.v1``). Each bench topic is one channel with its
``ros2msg`` schema (the message definition and its dependencies, as rosbag2 stores them in an
MCAP file) and ``cdr`` message encoding: the bytes sent are the bytes on DDS and in the bag,
so Foxglove decodes them as it decodes a bag. A browser cannot draw 1 kHz on four plots, so a
topic is forwarded at most ``max_rate_hz`` times a second (the first message in each period,
by receive time); the topics of ``full_rate_topics`` (the characteristic's points, the
protocol status, the step records) are always sent whole.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

from pam_bench.live.errors import LiveViewError

__all__ = ['LiveServer', 'Throttle', 'schema_text']


def schema_text(msgtype: str) -> str:
    """The ``ros2msg`` schema of ``msgtype`` (e.g. ``geometry_msgs/msg/WrenchStamped``): its
    definition, then each type it uses after a ``MSG:`` separator line."""
    from pam_bench.bags.types import bench_typestore
    text, _ = bench_typestore().generate_msgdef(msgtype, ros_version=2)
    return str(text)


@dataclasses.dataclass
class Throttle:
    """Pass at most one message per ``1 / max_rate_hz`` (0: every message).

    Attributes:
        max_rate_hz: the cap, Hz.
        next_ns: the earliest receive time of the next message passed, ns.
        passed: messages passed.
        dropped: messages held back.
    """

    max_rate_hz: float
    next_ns: int = 0
    passed: int = 0
    dropped: int = 0

    def admit(self, now_ns: int) -> bool:
        """Whether a message received at ``now_ns`` goes out."""
        if self.max_rate_hz <= 0.0 or now_ns >= self.next_ns:
            period = round(1e9 / self.max_rate_hz) if self.max_rate_hz > 0.0 else 0
            # keep the phase unless a whole period was skipped (no burst after a gap)
            late = now_ns - self.next_ns
            self.next_ns = self.next_ns + period if self.next_ns and late < period else \
                now_ns + period
            self.passed += 1
            return True
        self.dropped += 1
        return False


class LiveServer:
    """A Foxglove server with one channel per topic (module docstring).

    Args:
        host: the address it binds (127.0.0.1: this machine only).
        port: its TCP port (0: any free one).
        max_rate_hz: the cap of every topic not in ``full_rate_topics``.
        full_rate_topics: topics always sent whole.

    Raises:
        LiveViewError: the port is taken or the address cannot be bound.
    """

    def __init__(self, host: str = '127.0.0.1', port: int = 8765, max_rate_hz: float = 50.0,
                 full_rate_topics: tuple[str, ...] | list[str] = ()) -> None:
        import foxglove
        self.max_rate_hz = max_rate_hz
        self.full_rate_topics = set(full_rate_topics)
        self.channels: dict[str, Any] = {}
        self.throttles: dict[str, Throttle] = {}
        self._context = foxglove.Context()
        try:
            self._server = foxglove.start_server(name='pam_bench', host=host, port=port,
                                                 context=self._context)
        except RuntimeError as exc:
            reason = str(exc).split('FoxgloveError: ')[-1]
            raise LiveViewError(f'live view: cannot serve on {host}:{port}: {reason} '
                                '(pick another with --live PORT)') from None
        self.host = host
        self.port = int(self._server.port)

    @property
    def url(self) -> str:
        """The WebSocket address to open in Foxglove."""
        return f'ws://{self.host}:{self.port}'

    def add_topic(self, topic: str, msgtype: str) -> None:
        """Advertise ``topic`` of ``msgtype`` (idempotent)."""
        import foxglove
        if topic in self.channels:
            return
        schema = foxglove.Schema(name=msgtype, encoding='ros2msg',
                                 data=schema_text(msgtype).encode())
        self.channels[topic] = foxglove.Channel(topic, schema=schema, message_encoding='cdr',
                                                context=self._context)
        cap = 0.0 if topic in self.full_rate_topics else self.max_rate_hz
        self.throttles[topic] = Throttle(cap)

    def admit(self, topic: str, now_ns: int | None = None) -> bool:
        """Whether a message of ``topic`` received now goes out under its cap (counted)."""
        return self.throttles[topic].admit(time.monotonic_ns() if now_ns is None else now_ns)

    def send(self, topic: str, data: bytes, log_time_ns: int) -> None:
        """Send one admitted message's CDR bytes, stamped ``log_time_ns``."""
        self.channels[topic].log(data, log_time=log_time_ns)

    def offer(self, topic: str, data: bytes, log_time_ns: int,
              now_ns: int | None = None) -> bool:
        """``admit`` then ``send``; returns whether it went out."""
        if not self.admit(topic, now_ns):
            return False
        self.send(topic, data, log_time_ns)
        return True

    def stop(self) -> None:
        """Close the server and its connections."""
        self._server.stop()
