"""A node on a wall clock (``lockstep: false``): a real bench, or its emulation.

A device node steps itself every ``1 / rate_hz`` seconds of its own clock (``on_wall_tick``,
driven by ``runtime.process.deadline_spin`` or by the emulator process that composes the
devices). Each synchronous input is then simply the latest message received (``wall_inputs``
adapts sub-step sample lists to the device's own step); outputs are stamped with the node's
clock and published with ``DRIVER`` QoS. A controller ticks on its own period and waits, at
most ``startup_timeout_s``, for the measured topics (``waited_too_long``).
"""

from __future__ import annotations

import sys
from typing import Any

from diagnostic_msgs.msg import DiagnosticStatus

from pam_bench.models import jit
from pam_bench.runtime.core import NodeCore, Output
from pam_bench.runtime.intra import bus_publisher, bus_subscription
from pam_bench.runtime.qos import DRIVER, SENSOR
from pam_bench.sim.lockstep import InputSpec

__all__ = ['WallClock', 'WallClockStepping', 'RESEND_NS', 'MAX_CATCH_UP']

RESEND_NS = 100_000_000
"""On a wall clock a device still waiting for an input publishes its t_0 outputs again this
often (ns): a consumer that matched after they went out would otherwise wait for ever."""
MAX_CATCH_UP = 1000
"""Most periods one late tick steps the model over (1 s at 1 kHz)."""


class WallClock(NodeCore):
    """Ticking on a wall clock (module docstring)."""

    def _init_wallclock(self) -> None:
        self.wall_period_s: float | None = None     # set: ticked by on_wall_tick
        self._first_tick_ns: int | None = None
        self._recorded: set[str] = set()        # topics the recorder was seen on
        self.exit_code: int | None = None    # set: the node's work is done, its process exits
        self.wall_timer: Any = None

    def start_wall_ticks(self, period_s: float) -> None:
        """Tick ``on_wall_tick`` every ``period_s``: on an rclpy timer under any executor,
        until a lean loop takes the ticking over (``take_wall_ticks``).

        The process stays on the reference physics (``models.jit.use('python')``): a
        late tick steps several periods at once, and the first call of many sub-steps would
        otherwise load numba in a thread mid-run, holding the interpreter for half a second
        or more (a measured topic goes stale). A wall-clock period has a few sub-steps, which
        the reference runs as fast."""
        jit.use('python')
        self.wall_period_s = period_s
        self.count_periods(period_s)
        self.wall_timer = self.create_timer(period_s, self.wall_tick)

    def wall_tick(self, t_ns: int | None = None) -> None:
        """``on_wall_tick`` guarded: whatever it raises is diagnosed and puts the node in its
        safe state (``step_failed``) instead of leaving the timer's callback. A managed node
        that is not active does not step (``runtime.lifecycle``)."""
        try:
            if not self.may_step():
                return
            self.apply_tuning()
            self.on_wall_tick(t_ns)
        except Exception as exc:  # noqa: BLE001 - a callback must never let an exception out
            self.step_failed(exc)

    def take_wall_ticks(self) -> float:
        """Stop the node's own timer: the caller ticks ``on_wall_tick`` from now on (on a
        monotonic deadline, ``runtime.process.deadline_spin``). Returns the period (s)."""
        if self.wall_timer is not None:
            self.destroy_timer(self.wall_timer)
            self.wall_timer = None
        assert self.wall_period_s is not None
        return self.wall_period_s

    def now_ns(self) -> int:
        """The node's clock (ROS time: the system clock unless use_sim_time), ns."""
        return int(self.get_clock().now().nanoseconds)

    def on_wall_tick(self, t_ns: int | None = None) -> None:
        """One wall-clock step of a device at ``t_ns`` (default: now on the node's clock):
        its stepping's (``WallClockStepping.step``); a controller overrides this."""
        self.count_tick()
        self.stepping.step(self.now_ns() if t_ns is None else t_ns)

    def waited_too_long(self, t_ns: int, waiting_for: list[str], timeout_s: float,
                        since_ns: int | None = None, fatal: bool = True) -> str:
        """On a wall clock: whether a controller has waited more than ``timeout_s`` (since
        ``since_ns``, default its first tick) for the topics ``waiting_for``. If so it says
        which (one line on the log and /diagnostics) and, when ``fatal``, sets ``exit_code``
        3. Returns that line ('' while within the timeout)."""
        if self._first_tick_ns is None:
            self._first_tick_ns = t_ns
        start = self._first_tick_ns if since_ns is None else since_ns
        if not waiting_for or t_ns - start < timeout_s * 1e9:
            return ''
        text = (f'no data on {", ".join(waiting_for)} after {timeout_s:g} s: are the '
                'devices (or drivers) running?')
        if fatal and self.exit_code is None:
            self.diagnose(DiagnosticStatus.ERROR, text)
            print(f'{self.get_name()}: error: {text}', file=sys.stderr, flush=True)
            self.exit_code = 3
        return text

    def recorder_listens(self, topic: str, recorder: str = 'recorder') -> bool:
        """Whether the run's recorder (the node called ``recorder``, in any namespace)
        subscribes to ``topic`` as this node resolves it: another subscriber, such as the
        live view, does not count (what a controller publishes before the recorder is there
        goes unrecorded). The graph is asked until the recorder is seen, not at every tick
        after."""
        if topic in self._recorded:
            return True
        try:
            infos = self.get_subscriptions_info_by_topic(self.resolve_topic_name(topic))
        except Exception:  # noqa: BLE001 - a graph query must not end a callback
            return False
        if any(i.node_name == recorder for i in infos):
            self._recorded.add(topic)
            return True
        return False

    def wall_inputs(self, inputs: dict[str, Any], dt_s: float) -> dict[str, Any]:
        """On a wall clock: adapt the latest inputs to a step of ``dt_s`` (default: as they
        are)."""
        return inputs


class WallClockStepping:
    """A device's stepping on a wall clock: a ``runtime.stepping.Stepping``.

    Each synchronous input is the latest message received; at the first tick the node's
    ``on_start`` (what it publishes then is sent again every ``RESEND_NS`` while an input has
    not come: a subscriber that matched late missed it); then, once every input has arrived,
    ``on_step`` with the latest inputs (the node's ``wall_inputs``) over the whole periods
    that have passed: the model runs on a fixed grid of the node's ``wall_period_s`` that
    follows the clock to within half a period (a late tick steps two periods at once), so its
    exact discretisations (ZOH) are computed once, not at every jittered step. Outputs are
    stamped with the tick. A step that raises puts the device in its safe state and the node
    goes on.
    """

    def __init__(self, node: NodeCore) -> None:
        self.node = node
        self.last_ns: int | None = None           # the latest tick's stamp (None before)
        self._topics: list[str] = []
        self._latest: dict[str, Any] = {}
        self._model_ns = 0                          # the model's time
        self._resend_ns = 0
        self._start_outputs: list[Output] = []     # what on_start published
        self._capturing = False
        self._stopped = False
        self._waited = False                        # it said it waits for an input

    def publisher(self, msg_type: type, topic: str) -> Any:
        """A counted driver publisher (``runtime.stats``); what it publishes in ``on_start``
        is kept to be sent again while the node waits for an input."""
        pub = self.node.counted(bus_publisher(self.node, msg_type, topic, DRIVER), topic)
        send = pub.publish

        def publish(msg: Any, *args: Any) -> None:
            if self._capturing:
                self._start_outputs.append((send, msg))
            send(msg, *args)

        pub.publish = publish
        return pub

    def input(self, msg_type: type, topic: str, raw: bool = False,
              spec: InputSpec | None = None) -> None:
        """A synchronous input: the latest message (``raw`` and ``spec`` matter in lock-step
        only)."""
        self._topics.append(topic)
        latest = self._latest

        def on_latest(msg: Any) -> None:
            latest[topic] = msg

        bus_subscription(self.node, msg_type, topic, on_latest, SENSOR)

    # --- the Stepping protocol ----------------------------------------------------------
    def start(self) -> None:
        """Nothing to subscribe: the node's loop ticks ``step``."""

    def step(self, t_ns: int | None = None) -> None:
        """One tick at ``t_ns`` (class docstring)."""
        node = self.node
        if self._stopped:
            return
        t = node.now_ns() if t_ns is None else t_ns
        assert node.wall_period_s is not None
        period = round(node.wall_period_s * 1e9)
        if self.last_ns is None:
            self.last_ns = self._model_ns = self._resend_ns = t
            self._capturing = True
            try:
                node.on_start(t)
            finally:
                self._capturing = False
            return
        self.last_ns = t
        n = (t - self._model_ns + period // 2) // period
        if n <= 0:
            return
        if len(self._latest) < len(self._topics):   # a producer has not started yet
            self._model_ns = t
            if t - self._resend_ns >= RESEND_NS:  # what it waits for may need our t_0 outputs
                self._resend_ns = t
                for send, msg in self._start_outputs:
                    send(msg)
                missing = [node.resolve_topic_name(tp) for tp in self._topics
                           if tp not in self._latest]
                node.diagnose(DiagnosticStatus.WARN, f'waiting for {", ".join(missing)}: '
                              'nothing published until it comes', 'connections')
                self._waited = True
            return
        if self._waited:
            self._waited = False
            node.diagnose(DiagnosticStatus.OK, 'every input present: stepping', 'connections')
        n = min(n, MAX_CATCH_UP)
        self._model_ns = max(self._model_ns + n * period, t - period)
        try:
            node.on_step(t, n * period * 1e-9, node.wall_inputs(dict(self._latest),
                                                                n * period * 1e-9))
        except Exception as exc:  # noqa: BLE001 - a callback must never let an exception out
            self.fault(exc)

    def fault(self, exc: Exception) -> None:
        """A step raised: the node diagnoses it and goes to its safe state."""
        self.node.step_failed(exc)

    def stop(self) -> None:
        """No step after this one."""
        self._stopped = True
