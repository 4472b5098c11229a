"""A node's side of the lock-step: inputs buffered by stamp, one step per /clock tick, the ack.

Lock-step (docs/design.md, "Time"; the rules are ``sim.lockstep``): ``sim_clock`` publishes
/clock at t_k. A participant steps to t_k once it holds, for each of its synchronous inputs,
the message stamped exactly t_(k-1) (every participant publishes every output at every step).
It then publishes its outputs stamped t_k and a StepAck. Inputs are buffered by stamp, so a
fast producer's t_k output never replaces the t_(k-1) one a slower consumer still needs: the
run is deterministic whatever order DDS delivers messages in. At t_0 a participant only says it
is ready (its inputs have publishers); step 1 uses the initial values. With its acknowledgement
a participant may ask for a shorter next step (``max_next_step_s``), so that events such as a
reading or a 1 kHz record land exactly on the exchange grid.

Three options per input. ``same_step``: the participant steps to t_k with the message stamped
t_k itself (Gauss-Seidel along an open chain such as valve -> muscle -> load cell; the producer
must not depend on this participant within the same step). ``samples``: the input is the list
of every message stamped in the interval (previous, required], in stamp order: a producer may
publish sub-step samples between grid points, and the last one always sits on the grid.
``from_start``: a lagged input whose producer publishes it at t_0 too (in ``on_start``), so
step 1 needs it like every later step.

A message lost at start-up (a reader matched after the writer's first publish) would stall the
lock-step: while a tick is not acknowledged the clock publishes it again every ``nudge_s``; a
participant that already stepped to it publishes that step's outputs (those of
``create_step_publisher``) and its step before's again with its acknowledgement (a lagged
consumer, the recorder above all, needs the step before's), and one still waiting for its inputs
publishes its previous step's outputs again (the t_0 outputs of ``on_start`` among them), which
is what a consumer waiting on it may lack. Inputs are keyed by stamp, so a repeated message
changes nothing.
"""

from __future__ import annotations

from typing import Any

from pam_bench_interfaces.msg import StepAck
from rclpy.serialization import deserialize_message
from rosgraph_msgs.msg import Clock

from pam_bench.config import topics
from pam_bench.runtime.core import NodeCore, Output
from pam_bench.runtime.intra import bus_publisher, bus_subscription
from pam_bench.runtime.messages import ack_message, clock_ns, stamp_of_cdr, stamp_of_msg
from pam_bench.runtime.qos import LOCKSTEP, RELIABLE
from pam_bench.sim.lockstep import Ack, InputSpec, StepPlan

__all__ = ['LockstepStepping']


class LockstepStepping:
    """A node's stepping in lock-step (module docstring): a ``runtime.stepping.Stepping``.

    It owns the inputs' buffers, the steps' outputs and the handshake; it calls the node's
    ``on_start``, ``on_step`` and ``step_failed`` and reads its ``max_next_step_s`` and
    ``stop_request`` when it acknowledges.
    """

    def __init__(self, node: NodeCore) -> None:
        self.node = node
        self.last_ns: int | None = None           # the latest step's stamp (None before t_0)
        self._sync: dict[str, dict[int, Any]] = {}
        self._specs: dict[str, InputSpec] = {}
        self._decode: dict[str, type] = {}
        self._prev_prev_ns: int | None = None
        self._pending_ns: int | None = None
        self._waiting: tuple[Any, int] | None = None     # (buffer, stamp) the step waits for
        self._step_index = 0
        self._sent: list[Output] = []                    # this step's outputs
        self._sent_before: list[Output] = []             # the step before's
        self._ack_pub: Any = None
        self._plan: StepPlan | None = None
        self._stopped = False

    # --- declaring ----------------------------------------------------------------------
    def publisher(self, msg_type: type, topic: str) -> Any:
        """A publisher of a step output: what it publishes in a step is sent again when the
        clock repeats that tick (module docstring)."""
        pub = bus_publisher(self.node, msg_type, topic, LOCKSTEP)
        send = pub.publish
        send_many = getattr(pub, 'publish_many', None)

        def publish(msg: Any) -> None:
            self._sent.append((send, msg))
            send(msg)

        def publish_many(msgs: list[Any]) -> None:
            if send_many is None:
                for m in msgs:
                    publish(m)
                return
            self._sent.append((send_many, msgs))
            send_many(msgs)

        pub.publish = publish
        pub.publish_many = publish_many
        return pub

    def input(self, msg_type: type, topic: str, raw: bool = False,
              spec: InputSpec | None = None) -> None:
        """Subscribe to a synchronous input: buffered by stamp, required at every step
        (``spec``; with ``raw`` the message stays CDR bytes until a step uses it)."""
        node = self.node
        buf: dict[int, Any] = {}
        self._sync[topic] = buf
        spec = self._specs[topic] = spec or InputSpec()
        if node._bus is not None:            # message objects, in process

            def on_object(msg: Any) -> None:
                # about thirty deliveries per servo exchange: the stamp from rosidl's slots
                # (``stamp_of_msg`` where an object has none), and no try while this
                # participant has no tick pending or its step waits for another message
                try:
                    s = msg._header._stamp
                    buf[s._sec * 1_000_000_000 + s._nanosec] = msg
                except AttributeError:
                    buf[stamp_of_msg(msg)] = msg
                if self._pending_ns is not None:
                    waiting = self._waiting
                    if waiting is None or waiting[1] in waiting[0]:
                        self.step()

            def on_objects(msgs: list[Any]) -> None:
                for m in msgs:
                    buf[stamp_of_msg(m)] = m
                self.step()

            bus_subscription(node, msg_type, topic, on_object, LOCKSTEP, many=on_objects,
                             blocks=spec.blocks or not spec.samples)   # the grid: no block
            return
        if not raw:
            self._decode[topic] = msg_type

        def on_msg(data: bytes) -> None:
            # kept as CDR bytes and decoded only when a step uses it: sub-step samples that a
            # participant does not need cost a take, not a deserialisation
            buf[stamp_of_cdr(data)] = data
            self.step()

        node.create_subscription(msg_type, topic, on_msg, LOCKSTEP, raw=True)

    # --- the Stepping protocol ----------------------------------------------------------
    def start(self) -> None:
        """Subscribe to /clock and create the ack publisher (after every ``input``)."""
        node = self.node
        self._ack_pub = bus_publisher(node, StepAck, topics.ACK, RELIABLE)
        self._plan = StepPlan(self._sync, self._specs)
        bus_subscription(node, Clock, topics.CLOCK, self._on_clock, RELIABLE)
        if node._bus is None:        # a process of its own, maybe started by hand: say so once
            node.get_logger().info(
                'lock-step: waiting for /clock from sim_clock (pam-bench run starts it); to '
                'run this node on a wall clock, start it with -p lockstep:=false or a params '
                'file from pam-bench params SCENE --ros-yaml')

    def step(self, t_ns: int | None = None) -> None:
        """Step to the pending tick once its inputs are there (``t_ns`` is the clock's)."""
        t = self._pending_ns
        if t is None or self.last_ns is None:
            return
        waiting = self._waiting
        if waiting is not None and waiting[1] not in waiting[0]:
            return                        # what the step waits for has not come yet
        prev = self.last_ns
        plan = self._plan
        assert plan is not None
        self._waiting = plan.missing(prev, t, self._step_index)
        if self._waiting is not None:
            return
        inputs: dict[str, Any] = plan.take(self._prev_prev_ns, prev, t, self._step_index)
        for topic, cls in self._decode.items():
            if topic in inputs:
                val = inputs[topic]
                if not isinstance(val, list):
                    inputs[topic] = deserialize_message(val, cls)
                elif self._specs[topic].stamped:
                    inputs[topic] = [(k, deserialize_message(v, cls)) for k, v in val]
                else:
                    inputs[topic] = [deserialize_message(v, cls) for v in val]
        self._pending_ns = None
        self._sent_before, self._sent = self._sent, []
        self._prev_prev_ns = prev
        self.last_ns = t
        self._step_index += 1
        node = self.node
        try:
            node.apply_tuning()
            node.on_step(t, (t - prev) * 1e-9, inputs)
        except Exception as exc:  # noqa: BLE001 - a callback must never let an exception out
            self.fault(exc)
        node.diagnostics.tick(t)
        self._ack(t)

    def fault(self, exc: Exception) -> None:
        """A step raised: the node diagnoses it and goes to its safe state; the run goes
        on (the step is acknowledged)."""
        self.node.step_failed(exc)

    def stop(self) -> None:
        """No step after this one: a tick still pending is dropped."""
        self._stopped = True
        self._pending_ns = None

    # --- the handshake ------------------------------------------------------------------
    def _on_clock(self, msg: Clock) -> None:
        if self._stopped:
            return
        t = clock_ns(msg)
        node = self.node
        if self.last_ns is not None and t <= self.last_ns:
            if t == self.last_ns:         # the clock repeats t_0 until all are ready, and any
                for send, out in self._sent_before + self._sent:   # tick not acknowledged
                    send(out)
                self._ack(t)
            return
        if self.last_ns is None:
            if all(self._has_publisher(tp) for tp in self._sync):
                self.last_ns = t
                node.on_start(t)
                self._ack(t)
            return
        if self._pending_ns == t:
            # the clock publishes a tick again when it is not acknowledged in time: a consumer
            # may still miss what this participant sent at its last step (a reader matched
            # late drops a writer's first messages), so that goes out again
            for send, out in self._sent:
                send(out)
        self._pending_ns = t
        self._waiting = None
        self.step()

    def _has_publisher(self, topic: str) -> bool:
        node = self.node
        if node._bus is not None:
            return node._bus.has_publisher(node, topic)
        return node.count_publishers(topic) > 0

    def _ack(self, t: int) -> None:
        node = self.node
        ack = Ack(t, node._fqn, float(node.max_next_step_s), node.stop_request)
        if node._bus is not None:                 # in process: the plain object
            self._ack_pub.publish(ack, ack_message)
        else:
            self._ack_pub.publish(ack_message(ack))
