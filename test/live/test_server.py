"""The live view's server: rate caps, the schemas and bytes a Foxglove client gets, a port in
use as one line."""

from __future__ import annotations

import time

import pytest

from pam_bench.live.errors import LiveViewError
from pam_bench.live.server import LiveServer, Throttle, schema_text
from test.live.client import FoxgloveClient


@pytest.mark.parametrize('rate_hz, gaps_ms, passed', [
    (50.0, [1.0] * 100, 6),           # 1 kHz over 0..100 ms at 50 Hz: 0, 20, ..., 100 ms
    (50.0, [19.0, 1.0, 19.0, 1.0], 3),  # phase kept: 0, 20, 40 pass
    (50.0, [100.0, 1.0, 1.0], 2),      # after a gap: one, then the cap again
    (0.0, [1.0] * 10, 11),             # no cap
    (1000.0, [1.0] * 10, 11),          # the cap is the rate itself
])
def test_throttle_passes_one_per_period(rate_hz: float, gaps_ms: list[float],
                                        passed: int) -> None:
    th = Throttle(rate_hz)
    t = 10**9
    n = int(th.admit(t))
    for gap in gaps_ms:
        t += round(gap * 1e6)
        n += th.admit(t)
    assert n == passed
    assert th.passed == passed and th.dropped == len(gaps_ms) + 1 - passed


def test_schema_is_the_ros2msg_text_with_its_dependencies() -> None:
    text = schema_text('geometry_msgs/msg/WrenchStamped')
    assert text.splitlines()[:2] == ['std_msgs/Header header', 'geometry_msgs/Wrench wrench']
    assert 'MSG: geometry_msgs/Vector3' in text and 'MSG: std_msgs/Header' in text


def test_a_client_gets_capped_topics_capped_and_points_whole() -> None:
    server = LiveServer('127.0.0.1', 0, max_rate_hz=50.0,
                        full_rate_topics=['/protocol/point'])
    client = FoxgloveClient(server.url)
    try:
        server.add_topic('/load_cell_1/force', 'geometry_msgs/msg/WrenchStamped')
        server.add_topic('/protocol/point', 'pam_bench_interfaces/msg/CharacteristicPoint')
        client.start()
        assert client.subscribed.wait(10), client.error
        time.sleep(0.3)                     # the server has the subscriptions
        t0 = time.monotonic_ns()
        sent = []
        for i in range(200):                # 200 ms of 1 kHz
            data = bytes([0, 1, 0, 0]) + i.to_bytes(4, 'little') * 4
            if server.offer('/load_cell_1/force', data, 10**9 + i * 10**6,
                            now_ns=t0 + i * 10**6):
                sent.append(('/load_cell_1/force', 10**9 + i * 10**6, data))
            if i % 20 == 0:
                server.offer('/protocol/point', data, 10**9 + i * 10**6, now_ns=t0 + i * 10**6)
                sent.append(('/protocol/point', 10**9 + i * 10**6, data))
        deadline = time.monotonic() + 10
        while len(client.messages) < len(sent) and time.monotonic() < deadline:
            time.sleep(0.05)
    finally:
        client.stop()
        server.stop()
    assert client.error is None
    assert client.subprotocol == 'foxglove.sdk.v1'
    by_topic = {c['topic']: c for c in client.channels.values()}
    force = by_topic['/load_cell_1/force']
    assert (force['encoding'], force['schemaEncoding'], force['schemaName']) == \
        ('cdr', 'ros2msg', 'geometry_msgs/msg/WrenchStamped')
    assert force['schema'] == schema_text('geometry_msgs/msg/WrenchStamped')
    assert sorted(client.messages) == sorted(sent)
    assert sum(t == '/load_cell_1/force' for t, _, _ in sent) == 10      # 200 ms at 50 Hz
    assert sum(t == '/protocol/point' for t, _, _ in sent) == 10         # every one


def test_a_port_in_use_is_one_line() -> None:
    first = LiveServer('127.0.0.1', 0)
    try:
        with pytest.raises(LiveViewError, match=f'127.0.0.1:{first.port}: .*in use'):
            LiveServer('127.0.0.1', first.port)
    finally:
        first.stop()
