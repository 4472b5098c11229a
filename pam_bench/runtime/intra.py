"""Intra-process delivery for nodes composed in one process: no DDS, no serialisation.

rclpy has no intra-process shortcut: two nodes of one process still serialise every message
and pass it through DDS, and rclpy's executor wakes up once per message. When a scene is
composed (``pam-bench run``, ``Layout.COMPOSED``) the runner activates one ``IntraProcessBus``
before it builds the nodes. The bench nodes then create their lock-step and event topics
through it (``bus_publisher``, ``bus_subscription``):

* a publish hands the message object to every in-process subscription of the topic by
  appending (callback, message) to one FIFO queue, the way rclcpp's intra-process manager hands
  a message to its subscriptions;
* a publisher may hand over a list of messages at once (``publish_many``, a load cell's
  1 kHz record samples of one exchange): a subscription that takes lists gets the list as one
  delivery, the others one delivery per message, in order. Where every subscription of the
  topic takes blocks (``blocks_taken``: lock-step inputs that declare it) the list may hold a
  block of samples as one object (``runtime.messages.ForceSamples``); outside the process
  (DDS) it goes as its messages;
* ``spin_composed`` drains that queue in one loop for the whole process: no wait set, no
  task per message. Deliveries are queued, not called in place, so a tick that triggers the
  next tick never recurses;
* subscribers outside the process (a recorder, Foxglove, ``ros2 topic echo``) still get the
  messages over DDS: a bus publisher also publishes on its DDS publisher while that publisher
  has matched subscriptions (checked every ``refresh_s``), and in-process subscriptions are
  not DDS subscriptions, so nothing is delivered twice.

Topics fed from outside (a torque set point, a protocol goal) stay ordinary DDS entities,
served by an rclpy executor whenever the queue is empty and at least every ``refresh_s``.
Subscribers receive message objects where DDS would give them bytes (``raw``); they must not
change what they receive.
"""

from __future__ import annotations

import collections
import time
from collections.abc import Callable
from typing import Any

from rclpy.node import Node
from rclpy.qos import QoSProfile

from pam_bench.runtime.messages import ForceSamples

__all__ = ['IntraProcessBus', 'BusPublisher', 'spin_composed', 'bus_publisher',
           'bus_subscription']

Callback = Callable[[Any], None]


class BusPublisher:
    """A publisher that delivers in process and, when someone outside listens, over DDS."""

    def __init__(self, bus: IntraProcessBus, topic: str, dds: Any) -> None:
        self.bus, self.topic, self.dds = bus, topic, dds
        self.external = False
        self._subs = bus.subscribers(topic)
        self._many = bus.list_takers(topic)
        self._blocks = bus.block_takers(topic)

    def publish(self, msg: Any, to_msg: Callable[[Any], Any] | None = None) -> None:
        """Queue ``msg`` for every in-process subscription; publish it on DDS when someone
        outside listens. With ``to_msg``, ``msg`` may be a plain object (cheaper to build than
        a message) and ``to_msg(msg)`` is what goes on DDS."""
        queue = self.bus.queue
        subs = self._subs
        for cb in subs:
            queue.append((cb, msg))
        self.bus.deliveries += len(subs)
        if self.external:
            self.dds.publish(msg if to_msg is None else to_msg(msg))

    def publish_many(self, msgs: list[Any], to_msg: Callable[[Any], Any] | None = None
                     ) -> None:
        """``publish`` each of ``msgs`` in order: a subscription that takes lists gets them in
        one delivery (module docstring)."""
        queue = self.bus.queue
        many = self._many
        for i, cb in enumerate(self._subs):
            cb_many = many[i] if i < len(many) else None
            if cb_many is not None:
                queue.append((cb_many, msgs))
            else:
                queue.extend([(cb, m) for m in msgs])
        self.bus.deliveries += len(self._subs) * len(msgs)
        if self.external:
            for m in msgs:
                if isinstance(m, ForceSamples):
                    for x in m.messages():
                        self.dds.publish(x)
                else:
                    self.dds.publish(m if to_msg is None else to_msg(m))

    def blocks_taken(self) -> bool:
        """Whether a ``publish_many`` may hold a block of samples (``ForceSamples``): every
        in-process subscription takes blocks, and none outside the process listens."""
        blocks = self._blocks
        return (bool(blocks) and len(blocks) == len(self._subs) and all(blocks)
                and not self.external)

    def get_subscription_count(self) -> int:
        """In-process and DDS subscriptions together."""
        return len(self._subs) + self.dds.get_subscription_count()


class IntraProcessBus:
    """Topic -> in-process subscriptions, and the queue of deliveries (module docstring)."""

    def __init__(self) -> None:
        self._subs: dict[str, list[Callback]] = collections.defaultdict(list)
        self._many: dict[str, list[Callback | None]] = collections.defaultdict(list)
        self._blocks: dict[str, list[bool]] = collections.defaultdict(list)
        self._publishers: list[BusPublisher] = []
        self.queue: collections.deque[tuple[Callback, Any]] = collections.deque()
        self.deliveries = 0         # messages handed to in-process subscriptions so far

    def subscribers(self, topic: str) -> list[Callback]:
        """The live list of in-process callbacks of ``topic`` (full name)."""
        return self._subs[topic]

    def list_takers(self, topic: str) -> list[Callback | None]:
        """The live list, beside ``subscribers``, of each subscription's callback for a list of
        messages (None: it takes one message at a time)."""
        return self._many[topic]

    def block_takers(self, topic: str) -> list[bool]:
        """The live list, beside ``subscribers``, of whether each subscription takes blocks of
        samples (``BusPublisher.blocks_taken``)."""
        return self._blocks[topic]

    def publisher(self, node: Node, msg_type: type, topic: str, qos: Any) -> BusPublisher:
        """A bus publisher of ``topic`` for ``node`` (with its DDS publisher for outsiders)."""
        name = node.resolve_topic_name(topic)
        pub = BusPublisher(self, name, node.create_publisher(msg_type, topic, qos))
        self._publishers.append(pub)
        return pub

    def subscribe(self, node: Node, topic: str, callback: Callback,
                  many: Callback | None = None, blocks: bool = False) -> None:
        """Deliver every message published in process on ``topic`` to ``callback``; with
        ``many``, a list published at once to ``many`` in one call (with ``blocks``, a list
        that may hold blocks of samples)."""
        name = node.resolve_topic_name(topic)
        self._subs[name].append(callback)
        self._many[name].append(many)
        self._blocks[name].append(blocks and many is not None)

    def has_publisher(self, node: Node, topic: str) -> bool:
        """Whether some node of this process publishes ``topic``."""
        name = node.resolve_topic_name(topic)
        return any(p.topic == name for p in self._publishers)

    def refresh(self) -> None:
        """Look again whether each publisher has subscribers outside the process."""
        for p in self._publishers:
            p.external = p.dds.get_subscription_count() > 0

    def drain(self, budget: int) -> int:
        """Deliver up to ``budget`` queued messages in order; return how many were."""
        queue = self.queue
        n = 0
        while queue and n < budget:
            cb, msg = queue.popleft()
            cb(msg)
            n += 1
        return n


def spin_composed(bus: IntraProcessBus, nodes: list[Node], executor: Any,
                  refresh_s: float = 0.05, should_stop: Callable[[], bool] | None = None
                  ) -> None:
    """Run the composed process: drain the bus; between batches call each node's
    ``lean_poll`` and let ``executor`` serve the DDS entities (external topics, actions,
    timers) without blocking, and block on it only when there is nothing to deliver.

    Returns when ``should_stop()`` is true or the executor's context shuts down; exceptions
    of callbacks (the clock's SystemExit at the end of a run) propagate. ``refresh_s`` is
    50 ms: one ``spin_once`` over the DDS entities of ten nodes costs about as much as two
    exchanges of a servo run, and at 10 ms it took a sixth of servo_sin_t's wall time.
    """
    polls = [n.lean_poll for n in nodes if hasattr(n, 'lean_poll')]
    ctx = executor.context
    last = 0.0
    bus.refresh()
    while ctx.ok() and not (should_stop and should_stop()):
        delivered = bus.drain(2000)
        now = time.monotonic()
        if delivered and now - last < refresh_s:
            continue
        last = now
        for poll in polls:
            poll()
        bus.refresh()
        executor.spin_once(timeout_sec=0.0 if bus.queue else refresh_s)


def bus_publisher(node: Node, msg_type: type, topic: str, qos: QoSProfile) -> Any:
    """A publisher that goes through the intra-process bus the node was given (``bus=`` when
    it was built: the composed process hands its bus to each node, as rclpy hands nodes to an
    executor), else an ordinary DDS publisher."""
    bus: IntraProcessBus | None = getattr(node, '_bus', None)
    if bus is None:
        return node.create_publisher(msg_type, topic, qos)
    return bus.publisher(node, msg_type, topic, qos)


def bus_subscription(node: Node, msg_type: type, topic: str, callback: Callable[[Any], None],
                     qos: QoSProfile, raw: bool = False,
                     many: Callable[[list[Any]], None] | None = None,
                     blocks: bool = False) -> None:
    """A subscription served by the intra-process bus the node was given (the callback then
    gets message objects, also where ``raw`` asks for bytes, and ``many`` the lists published
    at once, with ``blocks`` blocks of samples among them), else by DDS."""
    bus: IntraProcessBus | None = getattr(node, '_bus', None)
    if bus is None:
        node.create_subscription(msg_type, topic, callback, qos, raw=raw)
    else:
        bus.subscribe(node, topic, callback, many, blocks)
