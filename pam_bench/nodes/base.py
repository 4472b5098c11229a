"""Shared machinery of the bench nodes: typed parameters, diagnostics and the lock-step step.

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

Wall clock (``lockstep: false``, a real bench or ``pam-bench run --wallclock``): a device node
steps itself every ``1 / rate_hz`` seconds of its own clock (``on_wall_tick``, driven by
``nodes.process.deadline_spin`` or by the emulator process that composes the devices). Each
synchronous input is then simply the latest message received (``wall_inputs`` adapts
sub-step sample lists to the device's own step); outputs are stamped with the node's clock and
published with ``DRIVER`` QoS. The node keeps its parameter services (``ros2 param get`` works
on a wall clock; in lock-step they stay off for speed), counts what it publishes on DDS and
writes those counts and its tick times to ``stats_file`` when it stops.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
import zlib
from array import array
from collections.abc import Callable
from typing import Any

import numpy as np
import yaml
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from pam_bench_interfaces.msg import StepAck
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.node import Node
from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_sensor_data,
)
from rclpy.serialization import deserialize_message
from rosgraph_msgs.msg import Clock

from pam_bench.config import topics
from pam_bench.models.errors import ParameterError
from pam_bench.models.params import ParamInfo, describe, from_mapping, param_infos
from pam_bench.nodes import intra
from pam_bench.nodes.intra import bus_publisher, bus_subscription
from pam_bench.nodes.messages import ack_message, ns_of, stamp_of_cdr, stamp_of_msg, time_of
from pam_bench.sim.faults import Fault, parse_faults, sensor_value
from pam_bench.sim.lockstep import Ack, InputSpec, StopRequest, prune, take_inputs

__all__ = ['BenchNode', 'RELIABLE', 'LOCKSTEP', 'DRIVER', 'SENSOR']

RELIABLE = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                      history=HistoryPolicy.KEEP_LAST, durability=DurabilityPolicy.VOLATILE)
# Lock-step inputs and outputs keep everything: a 1 kHz record puts 1000 load-cell samples on
# the wire in one exchange, and a bounded history would drop the oldest before the readers
# take them (a reader on a wall clock wants the latest instead: RELIABLE).
LOCKSTEP = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                      history=HistoryPolicy.KEEP_ALL, durability=DurabilityPolicy.VOLATILE)
# On a wall clock, as REP-2003 asks of sensor drivers: publish reliable (any subscriber can
# match, a recorder gets every message) with a history of 1 s at 1 kHz, volatile (with 100 ms,
# a sample the middleware dropped on its way to a busy recorder was sometimes overwritten
# before the recorder asked for it again: a gap in 1 of about 6 wall-clock runs); consumers
# that want the latest reading subscribe best effort (the sensor-data profile, deeper: 100).
DRIVER = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                    history=HistoryPolicy.KEEP_LAST, durability=DurabilityPolicy.VOLATILE)
RESEND_NS = 100_000_000
"""On a wall clock a device still waiting for an input publishes its t_0 outputs again this
often (ns): a consumer that matched after they went out would otherwise wait for ever."""
SENSOR = QoSProfile(depth=100, reliability=qos_profile_sensor_data.reliability,
                    history=HistoryPolicy.KEEP_LAST, durability=DurabilityPolicy.VOLATILE)


class BenchNode(Node):
    """Base of every bench node: parameters from dataclasses, diagnostics, lock-step."""

    def __init__(self, name: str, **kwargs: Any) -> None:
        # Parameters are read once at start-up; without the six parameter services every
        # executor wake-up waits on far fewer entities (about 2x faster lock-step).
        kwargs.setdefault('start_parameter_services', False)
        super().__init__(name, **kwargs)
        self.lockstep = self.declare_typed('lockstep', True,
                                           'step on /clock ticks in lock-step with sim_clock')
        self._sync: dict[str, dict[int, Any]] = {}
        self._specs: dict[str, InputSpec] = {}
        self._decode: dict[str, type] = {}
        self._prev_prev_ns: int | None = None
        self._last_ns: int | None = None
        self._pending_ns: int | None = None
        self._step_index = 0
        self.rejected_count = 0
        self.stop_request: StopRequest | None = None      # sent with every acknowledgement
        self.max_next_step_s = 0.0        # longest next exchange step wanted (0: any)
        self._sent: list[tuple[Callable[[Any], None], Any]] = []   # this step's outputs
        self._sent_before: list[tuple[Callable[[Any], None], Any]] = []   # the step before's
        self._bus = intra.current()
        self._fqn = self.get_fully_qualified_name()
        self._diag_pub = bus_publisher(self, DiagnosticArray, topics.DIAGNOSTICS, RELIABLE)
        self._ack_pub = None
        self.stats_file = self.declare_typed('stats_file', '', 'write the DDS publish counts '
                                             'and wall-clock tick times here at the end (JSON)')
        # wall clock (module docstring)
        self.wall_period_s: float | None = None     # set: ticked by on_wall_tick
        self._latest: dict[str, Any] = {}
        self._model_ns = 0                          # wall clock: the model's time
        self._resend_ns = 0
        self._first_tick_ns: int | None = None
        self._fault_epoch_ns: int | None = None
        self.faults: list[Fault] = []
        self._start_outputs: list[tuple[Callable[[Any], None], Any]] | None = None
        self._tick_ns = array('q')                  # monotonic ns of every wall tick
        self.published: dict[str, int] = {}         # topic -> messages published on DDS
        self.exit_code: int | None = None    # set: the node's work is done, its process exits
        self._counted_pubs: list[Any] = []
        if not self.lockstep:
            from rclpy.parameter_service import ParameterService
            self._parameter_service = ParameterService(self)

    # --- parameters --------------------------------------------------------------------
    def declare_typed(self, name: str, default: Any, text: str, unit: str = '',
                      low: float | None = None, high: float | None = None) -> Any:
        """Declare one parameter with a typed default and a descriptor; return its value."""
        info = ParamInfo(name, default, unit, low, high, text)
        desc = ParameterDescriptor(description=describe(info))
        if isinstance(default, float) and (low is not None or high is not None):
            desc.floating_point_range = [FloatingPointRange(
                from_value=float(low if low is not None else -1e300),
                to_value=float(high if high is not None else 1e300))]
        elif isinstance(default, int) and not isinstance(default, bool) and (
                low is not None or high is not None):
            desc.integer_range = [IntegerRange(from_value=int(low if low is not None else -2**62),
                                               to_value=int(high if high is not None else 2**62),
                                               step=0)]
        return self.declare_parameter(name, default, desc).value

    def declare_model(self, prefix: str, cls: type) -> Any:
        """Declare every field of a parameter dataclass under ``prefix.``; return the object.

        Raises:
            ParameterError: a value has the wrong type or is out of range (names the key).
        """
        values = {}
        for info in param_infos(cls):
            desc = ParameterDescriptor(description=describe(info))
            value = self.declare_parameter(f'{prefix}.{info.name}', info.default, desc).value
            values[info.name] = list(value) if isinstance(info.default, list) else value
        return from_mapping(cls, values, prefix=f'{self.get_name()}.{prefix}.')

    # --- diagnostics -------------------------------------------------------------------
    def diagnose(self, level: bytes, message: str, **values: Any) -> None:
        """Publish one DiagnosticStatus for this node and log it."""
        st = DiagnosticStatus(level=level, name=self.get_fully_qualified_name(),
                              message=message, hardware_id='pam_bench_sim')
        st.values = [KeyValue(key=k, value=str(v)) for k, v in values.items()]
        arr = DiagnosticArray()
        arr.header.stamp = time_of(self._last_ns or 0)
        arr.status = [st]
        self._diag_pub.publish(arr)
        if level == DiagnosticStatus.OK:
            self.get_logger().info(message)
        elif level == DiagnosticStatus.WARN:
            self.get_logger().warning(message)
        else:
            self.get_logger().error(message)

    def reject(self, what: str, value: Any) -> None:
        """Log, count and diagnose a rejected input."""
        self.rejected_count += 1
        self.diagnose(DiagnosticStatus.ERROR, f'rejected {what}: {value!r}',
                      rejected_count=self.rejected_count)

    @staticmethod
    def finite(*values: float) -> bool:
        """True when every value is a finite float."""
        return all(isinstance(v, (int, float)) and math.isfinite(v) for v in values)

    # --- lock-step ---------------------------------------------------------------------
    def create_step_publisher(self, msg_type: type, topic: str) -> Any:
        """A publisher of a step output: what it publishes in a step is sent again when the
        clock repeats that tick (module docstring)."""
        pub = bus_publisher(self, msg_type, topic, LOCKSTEP if self.lockstep else DRIVER)
        if not self.lockstep:
            return self.counted(pub, topic)
        send = pub.publish

        def publish(msg: Any) -> None:
            self._sent.append((send, msg))
            send(msg)

        pub.publish = publish
        return pub

    def counted(self, pub: Any, topic: str) -> Any:
        """Count what ``pub`` puts on DDS (``published``; with the sequence numbers the
        recorder sees, the count says whether a message was lost). Returns ``pub``."""
        name = self.resolve_topic_name(topic)
        self.published.setdefault(name, 0)
        send = pub.publish
        dds = getattr(pub, 'dds', None)               # a bus publisher: DDS only when external

        def publish(msg: Any, *args: Any) -> None:
            if dds is None or pub.external:
                self.published[name] += 1
            if self._start_outputs is not None:
                self._start_outputs.append((publish, msg))
            send(msg, *args)

        pub.publish = publish
        self._counted_pubs.append(pub)
        return pub

    def sync_input(self, msg_type: type, topic: str, raw: bool = False,
                   same_step: bool = False, samples: bool = False,
                   from_start: bool = False) -> None:
        """Subscribe to a synchronous input: buffered by stamp, required at every step.

        With ``raw`` the message stays CDR bytes and its stamp is read from the header, which
        every stamped message (and Clock) starts with. ``same_step``, ``samples`` and
        ``from_start``: see the module docstring.
        """
        buf: dict[int, Any] = {}
        self._sync[topic] = buf
        self._specs[topic] = InputSpec(same_step, samples, from_start)
        if not self.lockstep:                # wall clock: the latest message
            latest = self._latest

            def on_latest(msg: Any) -> None:
                latest[topic] = msg

            bus_subscription(self, msg_type, topic, on_latest, SENSOR)
            return
        if self._bus is not None:            # message objects, in process

            def on_object(msg: Any) -> None:
                buf[stamp_of_msg(msg)] = msg
                self._try_step()

            bus_subscription(self, msg_type, topic, on_object, LOCKSTEP)
            return
        if not raw:
            self._decode[topic] = msg_type

        def on_msg(data: bytes) -> None:
            # kept as CDR bytes and decoded only when a step uses it: sub-step samples that a
            # participant does not need cost a take, not a deserialisation
            buf[stamp_of_cdr(data)] = data
            self._try_step()

        self.create_subscription(msg_type, topic, on_msg, LOCKSTEP, raw=True)

    def start_stepping(self, default_rate_hz: float = 1000.0) -> None:
        """Start stepping (call after all sync_input): in lock-step on /clock, else on the
        node's own clock at ``rate_hz`` (declared here, used on a wall clock only)."""
        rate_hz = self.declare_typed('rate_hz', default_rate_hz, 'update rate on a wall clock '
                                     '(lockstep false)', 'Hz', 1.0, 10000.0)
        text = self.declare_typed('faults_yaml', '', 'wall clock: faults injected into this '
                                  "device (YAML list, sim.faults; from a scene's faults)")
        self.faults = parse_faults(yaml.safe_load(text) if text else [], [self.get_name()])
        if self.faults and self.lockstep:
            raise ParameterError(f'{self.get_name()}: faults run on a wall clock (lockstep '
                                 'false)')
        self._fault_rng = np.random.default_rng(zlib.crc32(self.get_name().encode()))
        if self.faults:        # the faults' time base: the run's start (its first status)
            from pam_bench_interfaces.msg import ProtocolStatus, TorqueServoState
            for cls, topic in ((ProtocolStatus, topics.STATUS),
                               (TorqueServoState, topics.SERVO_STATE)):
                self.create_subscription(cls, topic, self._run_started, RELIABLE)
        if self.lockstep:
            self.start_lockstep()
        else:
            self.start_wall_ticks(1.0 / rate_hz)

    def start_wall_ticks(self, period_s: float) -> None:
        """Tick ``on_wall_tick`` every ``period_s``: on an rclpy timer under any executor,
        until a lean loop takes the ticking over (``take_wall_ticks``)."""
        self.wall_period_s = period_s
        self.wall_timer = self.create_timer(period_s, self.on_wall_tick)

    def take_wall_ticks(self) -> float:
        """Stop the node's own timer: the caller ticks ``on_wall_tick`` from now on (on a
        monotonic deadline, ``nodes.process.deadline_spin``). Returns the period (s)."""
        if getattr(self, 'wall_timer', None) is not None:
            self.destroy_timer(self.wall_timer)
            self.wall_timer = None
        assert self.wall_period_s is not None
        return self.wall_period_s

    def start_lockstep(self) -> None:
        """Subscribe to /clock and create the ack publisher (call after all sync_input)."""
        self._ack_pub = bus_publisher(self, StepAck, topics.ACK, RELIABLE)
        bus_subscription(self, Clock, topics.CLOCK, self._on_clock, RELIABLE)

    def _on_clock(self, msg: Clock) -> None:
        t = ns_of(msg.clock)
        if self._last_ns is not None and t <= self._last_ns:
            if t == self._last_ns:        # the clock repeats t_0 until all are ready, and any
                for send, out in self._sent_before + self._sent:   # tick not acknowledged
                    send(out)
                self._ack(t)
            return
        if self._last_ns is None:
            if all(self._has_publisher(tp) for tp in self._sync):
                self._last_ns = t
                self.on_start(t)
                self._ack(t)
            return
        if self._pending_ns == t:
            # the clock publishes a tick again when it is not acknowledged in time: a consumer
            # may still miss what this participant sent at its last step (a reader matched
            # late drops a writer's first messages), so that goes out again
            for send, out in self._sent:
                send(out)
        self._pending_ns = t
        self._try_step()

    def _has_publisher(self, topic: str) -> bool:
        if self._bus is not None:
            return self._bus.has_publisher(self, topic)
        return self.count_publishers(topic) > 0

    def _try_step(self) -> None:
        t = self._pending_ns
        if t is None or self._last_ns is None:
            return
        prev = self._last_ns
        inputs = take_inputs(self._sync, self._specs, self._prev_prev_ns, prev, t,
                             self._step_index)
        if inputs is None:
            return
        for topic, cls in self._decode.items():
            if topic in inputs:
                val = inputs[topic]
                inputs[topic] = ([deserialize_message(v, cls) for v in val]
                                 if isinstance(val, list) else deserialize_message(val, cls))
        prune(self._sync, self._specs, prev, t)
        self._pending_ns = None
        self._sent_before, self._sent = self._sent, []
        self._prev_prev_ns = prev
        self._last_ns = t
        self._step_index += 1
        try:
            self.on_step(t, (t - prev) * 1e-9, inputs)
        except Exception as exc:  # noqa: BLE001 - a callback must never let an exception out
            self.diagnose(DiagnosticStatus.ERROR, f'step failed: {exc}')
            self.on_fault(str(exc))
        self._ack(t)

    def _ack(self, t: int) -> None:
        ack = Ack(t, self._fqn, float(self.max_next_step_s), self.stop_request)
        if self._bus is not None:                 # in process: the plain object
            self._ack_pub.publish(ack, ack_message)
        else:
            self._ack_pub.publish(ack_message(ack))

    # --- wall clock ----------------------------------------------------------------------
    def now_ns(self) -> int:
        """The node's clock (ROS time: the system clock unless use_sim_time), ns."""
        return int(self.get_clock().now().nanoseconds)

    def on_wall_tick(self, t_ns: int | None = None) -> None:
        """One wall-clock step of a device at ``t_ns`` (default: now on the node's clock).

        At the first tick ``on_start``; then, once every synchronous input has arrived,
        ``on_step`` with the latest inputs (``wall_inputs``) over the whole periods that have
        passed: the model runs on a fixed grid of ``wall_period_s`` that follows the clock to
        within half a period (a late tick steps two periods at once), so its exact
        discretisations (ZOH) are computed once, not at every jittered step. Outputs are
        stamped ``t_ns``. A step that raises puts the device in its safe state
        (``on_fault``) and the node goes on."""
        t = self.now_ns() if t_ns is None else t_ns
        self._tick_ns.append(time.monotonic_ns())
        period = round(self.wall_period_s * 1e9)
        if self._last_ns is None:
            self._last_ns = self._model_ns = self._resend_ns = t
            self._start_outputs = []
            self.on_start(t)
            self._sent, self._start_outputs = self._start_outputs, None
            return
        self._last_ns = t
        n = (t - self._model_ns + period // 2) // period
        if n <= 0:
            return
        if len(self._latest) < len(self._sync):   # a producer has not started yet
            self._model_ns = t
            if t - self._resend_ns >= RESEND_NS:  # what it waits for may need our t_0 outputs
                self._resend_ns = t                 # (a subscriber that matched late missed
                for send, msg in self._sent:        # them)
                    send(msg)
            return
        n = min(n, 1000)
        self._model_ns = max(self._model_ns + n * period, t - period)
        try:
            self.on_step(t, n * period * 1e-9, self.wall_inputs(dict(self._latest),
                                                                 n * period * 1e-9))
        except Exception as exc:  # noqa: BLE001 - a callback must never let an exception out
            self.diagnose(DiagnosticStatus.ERROR, f'step failed: {exc}')
            self.on_fault(str(exc))

    def declare_startup_timeout(self) -> float:
        """Declare a wall-clock controller's ``startup_timeout_s`` (``waited_too_long``)."""
        return float(self.declare_typed(
            'startup_timeout_s', 30.0, 'without lock-step: exit (code 3) when a measured topic '
            'has not come this long after start', 's', 0.1, 3600.0))

    def waited_too_long(self, t_ns: int, waiting_for: list[str], timeout_s: float) -> bool:
        """On a wall clock: whether a controller has waited more than ``timeout_s`` since its
        first tick for the topics ``waiting_for``; if so it says which (one line on stderr
        and /diagnostics) and sets ``exit_code`` 3."""
        if self._first_tick_ns is None:
            self._first_tick_ns = t_ns
        if not waiting_for or t_ns - self._first_tick_ns < timeout_s * 1e9:
            return False
        if self.exit_code is None:
            text = (f'no data on {", ".join(waiting_for)} after {timeout_s:g} s: are the '
                    'devices (or drivers) running?')
            self.diagnose(DiagnosticStatus.ERROR, text)
            print(f'{self.get_name()}: error: {text}', file=sys.stderr, flush=True)
            self.exit_code = 3
        return True

    def _run_started(self, msg: Any) -> None:
        if self._fault_epoch_ns is None:
            self._fault_epoch_ns = self.now_ns()

    def fault_time_s(self) -> float:
        """Seconds since the run started (the first protocol status or servo state this
        device received): the faults' time base; -1 before."""
        if self._fault_epoch_ns is None or self._last_ns is None:
            return -1.0
        return (self._last_ns - self._fault_epoch_ns) * 1e-9

    def faulty(self, value: float) -> float | None:
        """The measured ``value`` as the injected faults make it (None: not published)."""
        if not self.faults:
            return value
        return sensor_value(self.faults, self.fault_time_s(), value,
                            float(self._fault_rng.standard_normal()),
                            float(self._fault_rng.random()))

    def fault_active(self, kind: str) -> bool:
        """Whether an injected fault of ``kind`` acts now."""
        t = self.fault_time_s()
        return any(f.kind == kind and f.active(t) for f in self.faults)

    def wall_inputs(self, inputs: dict[str, Any], dt_s: float) -> dict[str, Any]:
        """On a wall clock: adapt the latest inputs to a step of ``dt_s`` (default: as they
        are)."""
        return inputs

    def wall_stats(self) -> dict[str, Any]:
        """What this node published on DDS (topic -> count) and its tick periods."""
        from pam_bench.analysis.timing import period_stats
        out: dict[str, Any] = {'node': self._fqn, 'published': dict(self.published)}
        if self.wall_period_s is not None and len(self._tick_ns) > 2:
            out['periods'] = period_stats(self._tick_ns, self.wall_period_s)
        return out

    def write_stats(self) -> None:
        """Write ``wall_stats`` to ``stats_file`` (when set)."""
        if self.stats_file:
            tmp = f'{self.stats_file}.part'
            with open(tmp, 'w', encoding='utf-8') as fh:
                json.dump(self.wall_stats(), fh)
            os.replace(tmp, self.stats_file)

    def destroy_node(self) -> None:
        """Let subscribers acknowledge what was published (a recorder gets the last
        messages), write the stats file, then go."""
        from rclpy.duration import Duration
        for pub in self._counted_pubs:
            dds = getattr(pub, 'dds', pub)
            try:
                dds.wait_for_all_acked(Duration(seconds=0.5))
            except Exception:  # noqa: BLE001 - best effort at shutdown
                pass
        try:
            self.write_stats()
        except OSError as exc:
            self.get_logger().error(f'stats file: {exc}')
        super().destroy_node()

    # --- to override -------------------------------------------------------------------
    def on_start(self, t_ns: int) -> None:
        """Called once at t_0, when the inputs have publishers."""

    def on_step(self, t_ns: int, dt_s: float, inputs: dict[str, Any]) -> None:
        """Advance the model to ``t_ns`` over ``dt_s``; ``inputs`` maps topic -> msg at t_(k-1)
        (empty at the first step). Publish every output stamped ``t_ns``."""
        raise NotImplementedError

    def on_fault(self, reason: str) -> None:
        """Put the device in its safe state after a failed step."""


