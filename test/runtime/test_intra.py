"""The intra-process bus by itself: order of delivery, no recursion, DDS only for outsiders."""

from __future__ import annotations

from typing import Any

from pam_bench.runtime.intra import BusPublisher, IntraProcessBus
from pam_bench.runtime.messages import ForceSamples, force_reading


class FakeDds:
    """Stands for an rclpy publisher: counts what goes out over DDS."""

    def __init__(self, outside: int = 0) -> None:
        self.outside = outside
        self.sent: list[Any] = []

    def get_subscription_count(self) -> int:
        return self.outside

    def publish(self, msg: Any) -> None:
        self.sent.append(msg)


def test_deliveries_are_queued_in_publish_order_and_drained_in_order() -> None:
    bus = IntraProcessBus()
    got: list[tuple[str, Any]] = []
    bus.subscribers('/a').append(lambda m: got.append(('a1', m)))
    bus.subscribers('/a').append(lambda m: got.append(('a2', m)))
    pub = BusPublisher(bus, '/a', FakeDds())
    pub.publish(1)
    pub.publish(2)
    assert got == []                                   # queued, not called in place
    assert bus.drain(10) == 4
    assert got == [('a1', 1), ('a2', 1), ('a1', 2), ('a2', 2)]
    assert bus.deliveries == 4                         # counted: one per subscriber
    BusPublisher(bus, '/nobody', FakeDds()).publish(3)
    assert bus.deliveries == 4


def test_a_chain_of_replies_runs_in_one_loop_without_recursion() -> None:
    bus = IntraProcessBus()
    ping, pong = BusPublisher(bus, '/ping', FakeDds()), BusPublisher(bus, '/pong', FakeDds())
    seen = []
    bus.subscribers('/ping').append(lambda n: pong.publish(n + 1))
    bus.subscribers('/pong').append(lambda n: (seen.append(n), ping.publish(n + 1)
                                               if n < 20000 else None))
    ping.publish(0)
    while bus.drain(1000):
        pass
    assert seen[-1] == 20001 and len(seen) == 10001   # deeper than Python's recursion limit


def test_dds_only_when_someone_outside_listens() -> None:
    bus = IntraProcessBus()
    inside: list[Any] = []
    bus.subscribers('/t').append(inside.append)
    dds = FakeDds(outside=0)
    pub = BusPublisher(bus, '/t', dds)
    bus._publishers.append(pub)
    bus.refresh()
    pub.publish('x')
    dds.outside = 1
    bus.refresh()
    pub.publish('y')
    pub.publish('z', lambda obj: f'msg({obj})')
    bus.drain(10)
    assert inside == ['x', 'y', 'z']
    assert dds.sent == ['y', 'msg(z)']
    assert pub.get_subscription_count() == 2


class FakeNode:
    """Stands for an rclpy node: resolves topic names as given."""

    @staticmethod
    def resolve_topic_name(topic: str) -> str:
        return topic


def test_a_list_goes_in_one_delivery_to_a_list_taker_and_one_by_one_to_others() -> None:
    bus = IntraProcessBus()
    got: list[tuple[str, Any]] = []
    node: Any = FakeNode()
    bus.subscribe(node, '/s', lambda m: got.append(('one', m)))
    bus.subscribe(node, '/s', lambda m: got.append(('many?', m)),
                  many=lambda ms: got.append(('many', list(ms))))
    dds = FakeDds(outside=1)
    pub = BusPublisher(bus, '/s', dds)
    pub.external = True
    pub.publish_many([1, 2, 3])
    pub.publish(4)
    bus.drain(100)
    assert got == [('one', 1), ('one', 2), ('one', 3), ('many', [1, 2, 3]), ('one', 4),
                   ('many?', 4)]
    assert bus.deliveries == 8                         # as if published one by one
    assert dds.sent == [1, 2, 3, 4]


def test_blocks_only_where_every_subscription_takes_them_and_none_outside() -> None:
    """A publisher may send a block of samples where every in-process subscription declared it
    takes blocks and nobody outside the process listens; outside, a block goes as its
    messages."""
    bus = IntraProcessBus()
    node: Any = FakeNode()
    got: list[Any] = []
    dds = FakeDds(outside=0)
    pub = BusPublisher(bus, '/f', dds)
    bus._publishers.append(pub)
    assert not pub.blocks_taken()                       # nobody to take them
    bus.subscribe(node, '/f', got.append, many=got.extend, blocks=True)
    assert pub.blocks_taken()
    bus.subscribe(node, '/f', got.append, blocks=True)  # one at a time: it cannot take blocks
    assert not pub.blocks_taken()

    bus2 = IntraProcessBus()
    pub2 = BusPublisher(bus2, '/f', dds)
    bus2._publishers.append(pub2)
    bus2.subscribe(node, '/f', got.append, many=got.extend, blocks=True)
    bus2.subscribe(node, '/f', got.append, many=got.extend)     # a list taker, not blocks
    assert not pub2.blocks_taken()

    bus3 = IntraProcessBus()
    pub3 = BusPublisher(bus3, '/f', dds)
    bus3._publishers.append(pub3)
    bus3.subscribe(node, '/f', got.append, many=got.extend, blocks=True)
    dds.outside = 1
    bus3.refresh()
    assert not pub3.blocks_taken()                      # someone outside listens
    block = ForceSamples([1_000_000, 2_000_000], [1.0, 2.0], 'load_cell_1')
    last = force_reading(3_000_000, 'load_cell_1', 3.0)
    pub3.publish_many([block, last])                    # sent before the flag was read
    assert dds.sent == [*block.messages(), last]
