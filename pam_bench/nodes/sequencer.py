"""sequencer: runs a characterisation protocol over the measured topics only.

Reads ``load_cell_N/force``, ``encoder/joint_state`` and ``valve_N/pressure``; commands
``valve_N/command`` and ``loading_servo/command`` at every tick; publishes one
``protocol/point`` at the end of every dwell, one ``protocol/step_response`` per recorded step,
and ``protocol/status``. The protocol logic is the pure
``pam_bench.protocol.sequencer.Sequencer``; this node only ticks it.

Start: with ``autostart`` the protocol named by ``protocol`` begins at t_0; otherwise (and at
any time when idle) a ``protocol/run`` RunProtocol goal starts one, with optional YAML
overrides. Cancelling the goal stops the run and vents the valve. A lock-step sequencer with
``autostart`` (a scene) serves no goals and spins on its subscriptions only; on a wall clock
an autostart sequencer serves no goals either.

Ticks: in lock-step (simulated bench) on every /clock tick, with the measurements of the same
exchange (the devices form a chain that ends here), asking the clock for a step that lands on
the next reading or on the end of a record (the valve and the load cell then report every
1 kHz sample inside the exchange), and for ``command_step_s`` at every new reading or phase
(the loading servo takes a new set value one exchange after it is sent); with ``lockstep:
false`` (real bench) every ``tick_period_s`` of its own clock (``nodes.process.deadline_spin``),
aborting when a measured topic is older than ``stale_timeout_s``. On a wall clock the autostart
protocol begins once every measured topic has arrived, and with ``stop_on_end`` the node exits
``end_linger_s`` after the protocol ends (code 0 done, 4 aborted, 5 cancelled), venting
meanwhile, so that a recorder gets the last points and status.
"""

from __future__ import annotations

import math
import time
from typing import Any

import yaml
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import WrenchStamped
from pam_bench_interfaces.action import RunProtocol
from pam_bench_interfaces.msg import (
    CharacteristicPoint,
    LoadCommand,
    ProtocolStatus,
    StepResponseRecord,
    ValveCommand,
)
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.task import Future
from sensor_msgs.msg import FluidPressure, JointState
from std_srvs.srv import Trigger

from pam_bench.config import topics
from pam_bench.config.protocols import load_protocols, parse_overrides, protocol_schedule
from pam_bench.models.constants import ATMOSPHERE_PA, LOAD_CELL_RANGE_N, PULLEY_PITCH_DIAMETER_M
from pam_bench.models.errors import ParameterError
from pam_bench.nodes.base import RELIABLE, SENSOR, BenchNode
from pam_bench.nodes.intra import bus_publisher
from pam_bench.nodes.messages import ns_of, time_of
from pam_bench.nodes.process import run_node
from pam_bench.protocol.schedules import with_approach
from pam_bench.protocol.sequencer import (
    COMMAND_STEP_S,
    RECORD_EXCHANGE_S,
    Limits,
    Measurement,
    Phase,
    Point,
    Sequencer,
    StepRecord,
)
from pam_bench.protocol.suspenders import Suspenders, parse_rules
from pam_bench.sim.lockstep import EventStepRequest, StopRequest

__all__ = ['SequencerNode', 'main']

PROGRESS_PERIOD_S = 2.0
"""On a wall clock, a progress line on stdout this often (s)."""
END_CODES = {Phase.DONE: 0, Phase.ABORTED: 4, Phase.CANCELLED: 5}
STATE_OF = {Phase.IDLE: ProtocolStatus.STATE_IDLE, Phase.SETTLE: ProtocolStatus.STATE_RUNNING,
            Phase.LEAD: ProtocolStatus.STATE_RUNNING, Phase.DWELL: ProtocolStatus.STATE_RUNNING,
            Phase.RECORD: ProtocolStatus.STATE_RUNNING, Phase.DONE: ProtocolStatus.STATE_DONE,
            Phase.PAUSED: ProtocolStatus.STATE_RUNNING,
            Phase.ABORTED: ProtocolStatus.STATE_ABORTED,
            Phase.CANCELLED: ProtocolStatus.STATE_CANCELLED}


class SequencerNode(BenchNode):
    """Thin node over ``protocols.Sequencer``."""

    def __init__(self, name: str = 'sequencer', **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        d = self.declare_typed
        self.channel = d('channel', 1, 'muscle channel under test', '-', 1, 2)
        self.protocol = d('protocol', 'demo', 'protocol started at t_0 with autostart')
        self.autostart = d('autostart', True, 'start the protocol at t_0 (else: on a goal)')
        path = d('protocols_file', '', 'YAML file of the protocols (empty: config/protocols.yaml)')
        overrides = d('protocol_overrides_yaml', '', 'YAML mapping merged over the autostart '
                      'protocol (e.g. a coarser grid)')
        self.status_period_s = d('status_period_s', 1.0, 'sim time between status messages',
                                 's', 1e-3, 1e6)
        self.stop_on_end = d('stop_on_end', True, 'ask the sim clock to end the run with '
                             'the protocol')
        self.tick_period_s = d('tick_period_s', 0.001, 'tick period without lock-step', 's',
                               1e-4, 1.0)
        self.stale_timeout_s = d('stale_timeout_s', 0.5, 'abort when a measured topic is '
                                 'older than this (without lock-step)', 's', 1e-3, 60.0)
        self.startup_timeout_s = self.declare_startup_timeout()
        self.await_recorder = d('await_recorder', False, 'without lock-step: start the '
                                'autostart protocol only once protocol/point has a subscriber '
                                "(the run's recorder), so that no point goes unrecorded")
        pause_action = d('pause_action', 'hold', "what a pause does: 'hold' the reading's set "
                         "values or 'vent' (0 V, drive off; the resume settles again)")
        if pause_action not in ('hold', 'vent'):
            raise ParameterError(f"sequencer.pause_action {pause_action!r}: 'hold' or 'vent'")
        self.pause_vent = pause_action == 'vent'
        self.suspenders = Suspenders(parse_rules(yaml.safe_load(d(
            'suspenders_yaml', '', 'YAML list of suspenders: {input: force | contraction | '
            'pressure, low, high, stale_s, resume_after_s} (protocol.suspenders)') or '') or []))
        self.end_linger_s = d('end_linger_s', 0.5, 'without lock-step: time between the end '
                              'of the protocol and the exit of the node (stop_on_end)', 's',
                              0.0, 60.0)
        self.record_exchange_s = d('record_exchange_s', RECORD_EXCHANGE_S, 'longest exchange '
                                   'step asked for during a step record (0: the whole record in '
                                   'one; the devices report every sample inside it)', 's', 0.0,
                                   10.0)
        self.command_step_s = d('command_step_s', COMMAND_STEP_S, 'exchange step asked for at '
                                'every new reading or phase (the loading servo takes a new set '
                                'value one exchange after it is sent)', 's', 1e-6, 10.0)
        self.resume_from_reading = d('resume_from_reading', 0, 'start the autostart protocol at '
                                     'this reading (pam-bench run --resume: the first one a '
                                     'previous bag lacks), approached along its series path',
                                     '-',
                                     0, 10**7)
        self.pulley_radius_m = d('pitch_diameter_m', PULLEY_PITCH_DIAMETER_M, 'pulley pitch '
                                 'diameter for x = r theta', 'm', 1e-3, 10.0) / 2.0
        self.limits = Limits(
            force_range_n=d('force_range_n', LOAD_CELL_RANGE_N, 'load cell range: abort '
                            'beyond', 'N', 1.0, 1e6),
            force_tolerance_n=d('force_tolerance_n', 10.0, 'servo force tolerance at a reading',
                                'N', 0.0, 1e5),
            force_tolerance_rel=d('force_tolerance_rel', 0.05, 'relative force tolerance', '-',
                                  0.0, 1.0),
            position_tolerance_m=d('position_tolerance_m', 1e-3, 'servo position tolerance at '
                                   'a reading', 'm', 0.0, 1.0),
            pressure_tolerance_pa=d('pressure_tolerance_pa', 0.0, 'abort when the valve '
                                    'pressure at a reading is further than this from k_v u '
                                    '(a stuck valve); 0: off', 'Pa', 0.0, 1e7),
            valve_gain_pa_per_v=d('valve_gain_pa_per_v', 1.0e5, 'valve gain k_v of that check',
                                  'Pa/V', 1.0, 1e7))
        self.table = load_protocols(path or None)
        self.core = (self._make(self.protocol, overrides, self.resume_from_reading)
                     if self.autostart else None)
        ch = self.channel
        self.cell_topic = topics.load_cell_force(ch)
        self.enc_topic = topics.ENCODER
        self.p_topic = topics.valve_pressure(ch)
        self.meas = Measurement(0.0, 0.0, 0.0)
        self.samples: list[tuple[float, float]] = []      # load-cell (stamp s, N) since a tick
        self.stamps: dict[str, float] = {}
        self.valve_pub = self.create_step_publisher(ValveCommand, topics.valve_command(ch))
        self.load_pub = self.create_step_publisher(LoadCommand, topics.LOAD_COMMAND)
        self.point_pub = bus_publisher(self, CharacteristicPoint, topics.POINT, RELIABLE)
        self.record_pub = bus_publisher(self, StepResponseRecord, topics.RECORD, RELIABLE)
        self.status_pub = bus_publisher(self, ProtocolStatus, topics.STATUS, RELIABLE)
        if not self.lockstep:
            for pub, topic in ((self.point_pub, topics.POINT), (self.record_pub, topics.RECORD),
                               (self.status_pub, topics.STATUS)):
                self.counted(pub, topic)
        self._end_ns: int | None = None       # wall clock: when the node exits
        self._next_progress_s = 0.0
        self.step_request = EventStepRequest(self.command_step_s)
        self._last_status_t = -math.inf
        self._last_phase: Phase | None = None
        self._start_pending = False
        self._goal: Any = None
        self._goal_done: Future | None = None
        # a lock-step scene that starts its protocol by itself takes no goals: no action
        # server, and the node spins on subscriptions only (nodes.process.lean_spin), which costs a
        # fraction of rclpy's executor per message (1 kHz records arrive 1000 samples a second)
        self.LEAN_SPIN = self.lockstep and self.autostart
        self.create_service(Trigger, topics.PAUSE, self._on_pause)
        self.create_service(Trigger, topics.RESUME, self._on_resume)
        self.action = None
        if not self.autostart:
            self.action = ActionServer(self, RunProtocol, topics.RUN, self._execute,
                                       goal_callback=self._on_goal,
                                       cancel_callback=lambda _: CancelResponse.ACCEPT)
        if self.lockstep:
            self.sync_input(WrenchStamped, self.cell_topic, samples=True, same_step=True)
            self.sync_input(JointState, self.enc_topic, same_step=True)
            self.sync_input(FluidPressure, self.p_topic, same_step=True)
            self.start_lockstep()
        else:
            self.create_subscription(WrenchStamped, self.cell_topic,
                                     lambda m: self._measured(self.cell_topic, m), SENSOR)
            self.create_subscription(JointState, self.enc_topic,
                                     lambda m: self._measured(self.enc_topic, m), SENSOR)
            self.create_subscription(FluidPressure, self.p_topic,
                                     lambda m: self._measured(self.p_topic, m), SENSOR)
            self._start_pending = self.core is not None   # autostart once measurements came
            self.start_wall_ticks(self.tick_period_s)

    def _make(self, name: str, overrides_yaml: str, start_index: int = 0) -> Sequencer:
        readings, settle = protocol_schedule(name, parse_overrides(overrides_yaml), self.table)
        readings, start_index = with_approach(readings, start_index)
        return Sequencer(name, readings, settle, self.limits, self.record_exchange_s,
                         start_index)

    # --- inputs -------------------------------------------------------------------------
    def _update(self, topic: str, msg: Any) -> None:
        if isinstance(msg, list):                   # load-cell samples of one exchange
            if topic == self.cell_topic and msg:
                self.samples += [(ns_of(m.header.stamp) * 1e-9, m.wrench.force.x)
                                 for m in msg[:-1]]
            for m in msg[-1:]:
                self._update(topic, m)
            return
        if topic == self.cell_topic:
            self.samples.append((ns_of(msg.header.stamp) * 1e-9, msg.wrench.force.x))
            self.meas = Measurement(msg.wrench.force.x, self.meas.contraction_m,
                                    self.meas.pressure_pa)
        elif topic == self.enc_topic:
            self.meas = Measurement(self.meas.force_n, msg.position[0] * self.pulley_radius_m,
                                    self.meas.pressure_pa)
        else:
            self.meas = Measurement(self.meas.force_n, self.meas.contraction_m,
                                    msg.fluid_pressure - ATMOSPHERE_PA)

    def _measured(self, topic: str, msg: Any) -> None:
        """A measurement from a driver (wall clock): a value that is not finite is rejected
        (counted on /diagnostics) and aborts a running protocol, which vents the valve."""
        value = (msg.wrench.force.x if topic == self.cell_topic else
                 msg.position[0] if topic == self.enc_topic and len(msg.position) else
                 getattr(msg, 'fluid_pressure', 0.0))
        if not self.finite(value):
            self.reject(f'measurement on {topic} (protocol aborted, valve vented)', value)
            if self.core is not None and self.core.running:
                self.core.stop(Phase.ABORTED, f'measured topic {topic} not finite')
            return
        self.stamps[topic] = ns_of(msg.header.stamp) * 1e-9
        self._update(topic, msg)

    # --- ticking ------------------------------------------------------------------------
    def on_start(self, t_ns: int) -> None:
        """Start the protocol at t_0 when autostart is set (its first commands go out at the
        end of a first exchange of ``command_step_s``)."""
        if self.core is not None:
            self.core.start(t_ns * 1e-9)
            self.max_next_step_s = self.command_step_s

    def on_step(self, t_ns: int, dt_s: float, inputs: dict[str, Any]) -> None:
        """Lock-step tick: take the measurements of t_k, tick the protocol."""
        for topic, msg in inputs.items():
            self._update(topic, msg)
        self._tick(t_ns)

    def on_wall_tick(self) -> None:
        """Wall-clock tick: check the measurements' age, tick the protocol; start the
        autostart protocol once every measured topic has arrived; exit after the end."""
        t_ns = self.now_ns()
        t = t_ns * 1e-9
        self._tick_ns.append(time.monotonic_ns())
        if self._end_ns is not None and t_ns >= self._end_ns:
            self.exit_code = END_CODES.get(self.core.phase, 4) if self.core else 0
        if self._start_pending and self.await_recorder and \
                self.point_pub.get_subscription_count() == 0 and \
                not self.waited_too_long(t_ns, ['a recorder on protocol/point'],
                                         self.startup_timeout_s):
            self._publish_commands(time_of(t_ns), 0.0, 0, 0.0)      # vented until then
            return
        if self._start_pending and len(self.stamps) < 3:
            self._publish_commands(time_of(t_ns), 0.0, 0, 0.0)      # vented until then
            self.waited_too_long(t_ns, [tp for tp in (self.cell_topic, self.enc_topic,
                                                      self.p_topic) if tp not in self.stamps],
                                 self.startup_timeout_s)
            return
        if self.core is not None and self.core.running and t >= self._next_progress_s:
            self._next_progress_s = t + PROGRESS_PERIOD_S
            c = self.core
            print(f'[wall] {c.name}: {c.points_done}/{c.total_points} readings, '
                  f'{t - c.t_start:.0f} s, ETA {c.remaining_s(t):.0f} s', flush=True)
        if self.core is not None and self.core.running:
            watched = self.suspenders.watched_stale() if self.suspenders.suspended else set()
            for topic, what in ((self.cell_topic, 'force'), (self.enc_topic, 'contraction'),
                                (self.p_topic, 'pressure')):
                if what in watched:        # its suspender holds the run while it is stale
                    continue
                age = t - self.stamps.get(topic, -math.inf)
                if age > self.stale_timeout_s:
                    self.core.stop(Phase.ABORTED, f'measured topic {topic} stale '
                                   f'({age:.3f} s old)')
                    self.diagnose(DiagnosticStatus.ERROR, self.core.reason)
                    break
        self._tick(t_ns)

    def _tick(self, t_ns: int) -> None:
        t = t_ns * 1e-9
        self._wake()
        if self._start_pending and self.core is not None:
            self.core.start(t)
            self._start_pending = False
        stamp = time_of(t_ns)
        core = self.core
        if core is None:
            self.samples = []
            self._publish_commands(stamp, 0.0, 0, 0.0)
            return
        samples, self.samples = self.samples, []
        self._suspend_check(t)
        cmd = core.tick(t, self.meas, samples)
        self._publish_commands(stamp, cmd.voltage_v, int(cmd.load_mode), cmd.load_value,
                               cmd.sample_period_s)
        if cmd.point is not None:
            self.point_pub.publish(self._point_msg(cmd.point, stamp))
        if cmd.record is not None:
            self.record_pub.publish(self._record_msg(cmd.record))
        if core.phase != self._last_phase or t - self._last_status_t >= self.status_period_s:
            self._publish_status(t, stamp)
        self.max_next_step_s = self.step_request.request(t, core.next_event_s(t),
                                                         (core.index, core.phase))
        if not core.running and core.phase != Phase.IDLE:
            self._finish_goal()
            if self.stop_on_end and self.autostart and not self.lockstep:
                if self._end_ns is None:
                    self._end_ns = t_ns + round(self.end_linger_s * 1e9)
            elif self.stop_on_end and self.autostart:
                self.stop_request = StopRequest(
                    END_CODES[core.phase], f'protocol {core.name} {core.phase.value}'
                    + (f': {core.reason}' if core.reason else ''))

    def _suspend_check(self, t: float) -> None:
        """Let the suspenders pause or resume a running protocol."""
        core = self.core
        if core is None or not core.running or not self.suspenders.rules:
            return
        m = self.meas
        values = {'force': m.force_n, 'contraction': m.contraction_m, 'pressure': m.pressure_pa}
        if self.lockstep:
            ages = dict.fromkeys(values, 0.0)
        else:
            ages = {'force': t - self.stamps.get(self.cell_topic, -math.inf),
                    'contraction': t - self.stamps.get(self.enc_topic, -math.inf),
                    'pressure': t - self.stamps.get(self.p_topic, -math.inf)}
        action, why = self.suspenders.update(t, values, ages)
        if action == 'suspend':
            core.pause(f'suspended: {why}', vent=self.pause_vent)
            self.diagnose(DiagnosticStatus.WARN, f'protocol suspended: {why}')
        elif action == 'resume':
            core.resume()
            self.diagnose(DiagnosticStatus.OK, 'suspender satisfied: protocol resumed')

    def _on_pause(self, request: Trigger.Request, response: Trigger.Response
                  ) -> Trigger.Response:
        """protocol/pause: pause at the next safe point (``pause_action``)."""
        core = self.core
        response.success = core is not None and core.running and core.phase != Phase.PAUSED
        if response.success:
            core.pause('paused by the operator', vent=self.pause_vent)
            self.diagnose(DiagnosticStatus.WARN, 'protocol pause requested')
        response.message = 'pausing at the next safe point' if response.success else \
            'nothing to pause'
        return response

    def _on_resume(self, request: Trigger.Request, response: Trigger.Response
                   ) -> Trigger.Response:
        """protocol/resume: end a pause (the interrupted reading is dwelt again)."""
        core = self.core
        response.success = core is not None and core.running and not self.suspenders.suspended
        if response.success:
            core.resume()
            self.diagnose(DiagnosticStatus.OK, 'protocol resume requested')
        response.message = ('resuming' if response.success else
                            'a suspender holds the run' if self.suspenders.suspended else
                            'nothing to resume')
        return response

    def _publish_commands(self, stamp: Any, u: float, mode: int, value: float,
                          sample_period_s: float = 0.0) -> None:
        v = ValveCommand(voltage=u, sample_period=sample_period_s)
        v.header.stamp = stamp
        self.valve_pub.publish(v)
        lc = LoadCommand(mode=mode, channel=self.channel, setpoint=value)
        lc.header.stamp = stamp
        self.load_pub.publish(lc)

    def _point_msg(self, pt: Point, stamp: Any) -> CharacteristicPoint:
        r, m = pt.reading, pt.measurement
        msg = CharacteristicPoint(protocol=r.protocol, series=r.series, step=r.step,
                                  direction=int(r.direction), series_value=r.series_value,
                                  set_value=r.set_value, voltage=pt.voltage_v, force=m.force_n,
                                  contraction=m.contraction_m, pressure=m.pressure_pa)
        msg.header.stamp = stamp
        return msg

    def _record_msg(self, pt: StepRecord) -> StepResponseRecord:
        r = pt.reading
        msg = StepResponseRecord(series=r.series, step=r.step, direction=int(r.direction),
                                 contraction=r.series_value,
                                 voltage_initial=float(r.pre_voltage_v or 0.0),
                                 voltage_final=r.voltage_v, sample_period=r.sample_period_s,
                                 force=list(pt.samples))
        msg.header.stamp = time_of(round(pt.t_step_s * 1e9))
        return msg

    def _publish_status(self, t: float, stamp: Any) -> None:
        c = self.core
        total = c.total_points
        msg = ProtocolStatus(protocol=c.name, state=STATE_OF[c.phase], phase=c.phase.value,
                             points_done=c.points_done, points_total=total,
                             progress=c.points_done / total, elapsed=t - c.t_start,
                             remaining=c.remaining_s(t), reason=c.reason or c.pause_reason)
        msg.header.stamp = stamp
        self.status_pub.publish(msg)
        self._last_status_t = t
        self._last_phase = c.phase
        if self._goal is not None and c.running:
            fb = RunProtocol.Feedback(progress=msg.progress, points_done=msg.points_done,
                                      points_total=total, phase=msg.phase,
                                      remaining=msg.remaining)
            self._goal.publish_feedback(fb)

    # --- action -------------------------------------------------------------------------
    def _on_goal(self, goal: RunProtocol.Goal) -> GoalResponse:
        if self.core is not None and (self.core.running or self._start_pending):
            self.get_logger().warning('protocol goal rejected: a protocol is running')
            return GoalResponse.REJECT
        try:
            self.core = self._make(goal.protocol, goal.overrides_yaml)
        except ParameterError as exc:
            self.diagnose(DiagnosticStatus.ERROR, f'protocol goal rejected: {exc}')
            return GoalResponse.REJECT
        self._start_pending = True
        return GoalResponse.ACCEPT

    async def _execute(self, goal_handle: Any) -> RunProtocol.Result:
        self._goal = goal_handle
        self._goal_done = Future()
        core = self.core
        while not self._goal_done.done():
            if goal_handle.is_cancel_requested and core.running:
                core.stop(Phase.CANCELLED, 'cancelled by the client')
            await self._wait_tick()
        self._goal = None
        result = RunProtocol.Result(success=core.phase == Phase.DONE, reason=core.reason,
                                    points=core.points_done)
        if core.phase == Phase.CANCELLED:
            goal_handle.canceled()
        elif core.phase == Phase.DONE:
            goal_handle.succeed()
        else:
            goal_handle.abort()
        return result

    async def _wait_tick(self) -> None:
        fut = Future()
        self._tick_waiter = fut
        await fut

    def _finish_goal(self) -> None:
        if self._goal_done is not None and not self._goal_done.done():
            self._goal_done.set_result(True)
        self._wake()

    def _wake(self) -> None:
        fut = getattr(self, '_tick_waiter', None)
        if fut is not None and not fut.done():
            fut.set_result(True)

    def on_fault(self, reason: str) -> None:
        """Abort: the next tick vents the valve."""
        if self.core is not None:
            self.core.stop(Phase.ABORTED, reason)
        self.diagnose(DiagnosticStatus.ERROR, f'protocol aborted: {reason}')


def main(args: list[str] | None = None) -> None:
    """Run the node."""
    run_node(SequencerNode, args)


if __name__ == '__main__':
    main()
