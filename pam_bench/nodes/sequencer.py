"""sequencer: runs a characterisation protocol over the measured topics only.

Reads ``load_cell_N/force``, ``encoder/joint_state`` and ``valve_N/pressure`` (and on a wall
clock ``loading_servo/state``, whose age says the drive follows: input ``drive``); commands
``valve_N/command`` and ``loading_servo/command`` at every tick; publishes one
``protocol/point`` at the end of every dwell, one ``protocol/step_response`` per recorded step,
and ``protocol/status``. The protocol logic and its policies (start gating, stale and
non-finite inputs, suspenders, pause, end codes) are the pure ``pam_bench.protocol.runner
.Runner``, which the twin ticks too; this node only turns messages into its inputs and its
ticks into messages.

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
false`` (real bench) every ``tick_period_s`` of its own clock (``runtime.process.deadline_spin``),
aborting when a measured topic is older than ``stale_timeout_s``. On a wall clock the autostart
protocol begins once every measured topic has arrived, and with ``stop_on_end`` the node exits
``end_linger_s`` after the protocol ends (code 0 done, 4 aborted, 5 cancelled), venting
meanwhile, so that a recorder gets the last points and status.
"""

from __future__ import annotations

import functools
import math
from typing import Any

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
from pam_bench.config.settings import SequencerSettings
from pam_bench.models.constants import ATMOSPHERE_PA
from pam_bench.protocol.io import Point, StepRecord
from pam_bench.protocol.runner import Runner, Tick, suspenders_of
from pam_bench.protocol.schedules import with_approach
from pam_bench.protocol.sequencer import Phase, Sequencer
from pam_bench.runtime.base import RELIABLE, SENSOR, BenchNode, Spin
from pam_bench.runtime.intra import bus_publisher
from pam_bench.runtime.messages import ForceSamples, ns_of, time_of
from pam_bench.runtime.process import run_node
from pam_bench.runtime.qos import LATCHED
from pam_bench.runtime.stamped import joint_effort, joint_position, stamped
from pam_bench.vocabulary.errors import PamBenchError, ParameterError

__all__ = ['SequencerNode', 'main']

PROGRESS_PERIOD_S = 2.0
"""On a wall clock, a progress line on stdout this often (s)."""
STATE_OF = {Phase.IDLE: ProtocolStatus.STATE_IDLE, Phase.SETTLE: ProtocolStatus.STATE_RUNNING,
            Phase.LEAD: ProtocolStatus.STATE_RUNNING, Phase.DWELL: ProtocolStatus.STATE_RUNNING,
            Phase.RECORD: ProtocolStatus.STATE_RUNNING, Phase.DONE: ProtocolStatus.STATE_DONE,
            Phase.PAUSED: ProtocolStatus.STATE_RUNNING,
            Phase.ABORTED: ProtocolStatus.STATE_ABORTED,
            Phase.CANCELLED: ProtocolStatus.STATE_CANCELLED}
LEVELS = {'ok': DiagnosticStatus.OK, 'warn': DiagnosticStatus.WARN,
          'error': DiagnosticStatus.ERROR}


class SequencerNode(BenchNode):
    """Thin node over ``protocol.runner.Runner``."""

    SETTINGS = SequencerSettings

    def __init__(self, name: str = 'sequencer', **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        s: SequencerSettings = self.settings
        self.autostart = s.autostart
        self.pulley_radius_m = s.pitch_diameter_m / 2.0
        ch = self.channel = s.channel
        self.cell_topic = topics.load_cell_force(ch)
        self.enc_topic = topics.ENCODER
        self.p_topic = topics.valve_pressure(ch)
        self.inputs = {self.cell_topic: 'force', self.enc_topic: 'contraction',
                       self.p_topic: 'pressure', topics.LOAD_STATE: 'drive'}
        self.runner = Runner(s, self.lockstep, end_run=s.stop_on_end and s.autostart,
                             labels={v: f'topic {k}' for k, v in self.inputs.items()})
        self.table = load_protocols(s.protocols_file or None)
        if self.autostart:
            self.runner.load(self._make(s.protocol, s.protocol_overrides_yaml,
                                        s.resume_from_reading))
        self.valve_pub = self.create_step_publisher(ValveCommand, topics.valve_command(ch))
        self.load_pub = self.create_step_publisher(LoadCommand, topics.LOAD_COMMAND)
        self.point_pub = bus_publisher(self, CharacteristicPoint, topics.POINT, RELIABLE)
        self.record_pub = bus_publisher(self, StepResponseRecord, topics.RECORD, RELIABLE)
        self.status_pub = bus_publisher(self, ProtocolStatus, topics.STATUS, LATCHED)
        if not self.lockstep:
            for pub, topic in ((self.point_pub, topics.POINT), (self.record_pub, topics.RECORD),
                               (self.status_pub, topics.STATUS)):
                self.counted(pub, topic)
        self._next_progress_s = 0.0
        self._idle_status_t = -math.inf            # last status sent with no protocol running
        self._loaded_ns: int | None = None         # when the goal's protocol was loaded
        self._goal: Any = None
        self._goal_done: Future | None = None
        self._tick_waiter: Future | None = None
        self.create_service(Trigger, topics.PAUSE, self._on_pause)
        self.create_service(Trigger, topics.RESUME, self._on_resume)
        self.action = None
        if not self.autostart:
            self.action = ActionServer(self, RunProtocol, topics.RUN, self._execute,
                                       goal_callback=self._on_goal,
                                       cancel_callback=lambda _: CancelResponse.ACCEPT)
        if self.lockstep:
            self.sync_input(WrenchStamped, self.cell_topic, samples=True, same_step=True,
                            blocks=True)
            self.sync_input(JointState, self.enc_topic, same_step=True)
            self.sync_input(FluidPressure, self.p_topic, same_step=True)
            self.start_lockstep()
        else:
            for cls, topic in ((WrenchStamped, self.cell_topic), (JointState, self.enc_topic),
                               (FluidPressure, self.p_topic), (JointState, topics.LOAD_STATE)):
                self.create_subscription(cls, topic, functools.partial(self._measured, topic),
                                         SENSOR)
            self.start_wall_ticks(s.tick_period_s)

    @property
    def core(self) -> Sequencer | None:
        """The protocol's state machine (None before a protocol is loaded)."""
        return self.runner.core

    def spin_mode(self) -> Spin:
        """A sequencer serving goals needs rclpy's executor (its action server); a lock-step
        scene that starts its protocol by itself spins on its subscriptions only (the pause
        and resume services are served between messages)."""
        if self.action is not None:
            return Spin.EXECUTOR
        return super().spin_mode()

    def _make(self, name: str, overrides_yaml: str, start_index: int = 0) -> Sequencer:
        s: SequencerSettings = self.settings
        readings, settle = protocol_schedule(name, parse_overrides(overrides_yaml), self.table)
        readings, start_index = with_approach(readings, start_index)
        return Sequencer(name, readings, settle, self.runner.limits, s.record_exchange_s,
                         start_index)

    # --- inputs -------------------------------------------------------------------------
    def _value(self, topic: str, msg: Any) -> float:
        if topic == self.cell_topic:
            return float(msg.wrench.force.x)
        if topic == self.enc_topic:
            return joint_position(msg, self.settings.joint_name) * self.pulley_radius_m
        if topic == topics.LOAD_STATE:
            return joint_effort(msg, topics.MOTOR_JOINT)
        return float(msg.fluid_pressure - ATMOSPHERE_PA)

    def _update(self, topic: str, msg: Any) -> None:
        if isinstance(msg, list):                   # load-cell samples of one exchange
            if topic == self.cell_topic and msg:
                points: list[tuple[float, float]] = []
                for m in msg[:-1]:
                    if m.__class__ is ForceSamples:        # in process (runtime.intra)
                        points += m.points()
                    else:
                        points.append((ns_of(m.header.stamp) * 1e-9, m.wrench.force.x))
                self.runner.samples_in(points)
            for m in msg[-1:]:
                self._update(topic, m)
            return
        self._measured(topic, msg)

    def _measured(self, topic: str, msg: Any) -> None:
        """A measurement; a value that is not finite is rejected (counted on /diagnostics)
        and aborts a running protocol, which vents the valve."""
        value = self._value(topic, msg)
        rejected = self.runner.measured(self.inputs[topic], value,
                                        ns_of(msg.header.stamp) * 1e-9)
        if rejected:
            self.reject(rejected, value)

    # --- ticking ------------------------------------------------------------------------
    def on_start(self, t_ns: int) -> None:
        """Start the protocol at t_0 when autostart is set (its first commands go out at the
        end of a first exchange of ``command_step_s``)."""
        if self.runner.core is not None and self.autostart:
            self.runner.start(t_ns * 1e-9)
            self.max_next_step_s = self.settings.command_step_s

    def on_step(self, t_ns: int, dt_s: float, inputs: dict[str, Any]) -> None:
        """Lock-step tick: take the measurements of t_k, tick the protocol."""
        for topic, msg in inputs.items():
            self._update(topic, msg)
        self._tick(t_ns)

    def on_wall_tick(self, t_ns: int | None = None) -> None:
        """Wall-clock tick: the runner checks the inputs' age and starts the autostart
        protocol once every measured topic (and the recorder) is there."""
        t_ns = self.now_ns() if t_ns is None else t_ns
        self.count_tick()
        s: SequencerSettings = self.settings
        gate = ('a recorder on protocol/point' if s.await_recorder
                and not self.recorder_listens(topics.POINT) else '')
        core = self.runner.core
        t = t_ns * 1e-9
        if core is not None and core.running and t >= self._next_progress_s:
            self._next_progress_s = t + PROGRESS_PERIOD_S
            how = (f'{core.pause_reason}' if core.phase == Phase.PAUSED
                   else f'ETA {core.remaining_s(t):.0f} s')
            self.get_logger().info(f'[wall] {core.name}: {core.points_done}/'
                                   f'{core.total_points} readings, {t - core.t_start:.0f} s, '
                                   + how)
        self._tick(t_ns, gate)

    def _tick(self, t_ns: int, gate: str = '') -> None:
        t = t_ns * 1e-9
        self._wake()
        tick = self.runner.tick(t, gate)
        stamp = time_of(t_ns)
        for note in tick.notes:
            self.diagnose(LEVELS[note.level], note.text)
        if tick.waiting:
            self._wait_or_give_up(t_ns, tick.waiting)
        self._send(stamp, tick)
        if tick.exit_code is not None:
            self.exit_code = tick.exit_code
        core = self.runner.core
        if core is None or tick.waiting:
            if t - self._idle_status_t >= self.settings.status_period_s:
                self._idle_status_t = t              # a late joiner learns the node is there
                self._publish_idle(stamp, tick.waiting)
            return
        if tick.status_due:
            self._publish_status(t, stamp)
        self.max_next_step_s = tick.next_step_s
        if self.runner.ended:
            self._finish_goal()
        if tick.stop is not None:
            self.stop_request = tick.stop

    def _wait_or_give_up(self, t_ns: int, waiting: list[str]) -> None:
        """Still waiting to start: past ``startup_timeout_s`` an autostart run ends (exit 3);
        a goal is aborted with the reason and the server stays up for the next one."""
        names = [w for w in waiting if w not in self.inputs.values()] + \
            [tp for tp, n in self.inputs.items() if n in waiting]
        goal_mode = self.action is not None
        text = self.waited_too_long(t_ns, names, self.settings.startup_timeout_s,
                                    since_ns=self._loaded_ns if goal_mode else None,
                                    fatal=not goal_mode)
        if text and goal_mode:
            self.runner.abort_start(text)
            self.diagnose(DiagnosticStatus.ERROR, f'protocol goal aborted: {text}')

    def _publish_idle(self, stamp: Any, waiting: list[str]) -> None:
        """The status while no protocol runs: idle, or loaded and waiting for its inputs."""
        core = self.runner.core
        msg = ProtocolStatus(protocol=core.name if core is not None else '',
                             state=ProtocolStatus.STATE_IDLE, phase=Phase.IDLE.value,
                             points_total=core.total_points if core is not None else 0,
                             reason=f'waiting for {", ".join(waiting)}' if waiting else '')
        msg.header.stamp = stamp
        self.status_pub.publish(msg)

    def _send(self, stamp: Any, tick: Tick) -> None:
        cmd = tick.commands
        self._publish_commands(stamp, cmd.voltage_v, int(cmd.load_mode), cmd.load_value,
                               cmd.sample_period_s)
        if tick.point is not None:
            self.point_pub.publish(self._point_msg(tick.point, stamp))
        if tick.record is not None:
            self.record_pub.publish(self._record_msg(tick.record))

    def _on_pause(self, request: Trigger.Request, response: Trigger.Response
                  ) -> Trigger.Response:
        """protocol/pause: pause at the next safe point (``pause_action``)."""
        response.success, response.message = self.runner.pause()
        self._notes_now()
        return response

    def _on_resume(self, request: Trigger.Request, response: Trigger.Response
                   ) -> Trigger.Response:
        """protocol/resume: end a pause (the interrupted reading is dwelt again)."""
        response.success, response.message = self.runner.resume()
        self._notes_now()
        return response

    def _notes_now(self) -> None:
        for note in self.runner.take_notes():
            self.diagnose(LEVELS[note.level], note.text)

    def _publish_commands(self, stamp: Any, u: float, mode: int, value: float,
                          sample_period_s: float = 0.0) -> None:
        t_ns = ns_of(stamp)
        self.valve_pub.publish(stamped(ValveCommand, t_ns, voltage=u,
                                       sample_period=sample_period_s))
        self.load_pub.publish(stamped(LoadCommand, t_ns, mode=mode, channel=self.channel,
                                      setpoint=value))

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
        c = self.runner.core
        assert c is not None
        total = c.total_points
        msg = ProtocolStatus(protocol=c.name, state=STATE_OF[c.phase], phase=c.phase.value,
                             points_done=c.points_done, points_total=total,
                             progress=c.points_done / total, elapsed=t - c.t_start,
                             remaining=c.remaining_s(t), reason=c.reason or c.pause_reason)
        msg.header.stamp = stamp
        self.status_pub.publish(msg)
        if self._goal is not None and c.running:
            fb = RunProtocol.Feedback(progress=msg.progress, points_done=msg.points_done,
                                      points_total=total, phase=msg.phase,
                                      remaining=msg.remaining)
            self._goal.publish_feedback(fb)

    # --- action -------------------------------------------------------------------------
    def _on_goal(self, goal: RunProtocol.Goal) -> GoalResponse:
        if self.runner.busy:
            self.get_logger().warning('protocol goal rejected: a protocol is running')
            return GoalResponse.REJECT
        try:
            self.runner.load(self._make(goal.protocol, goal.overrides_yaml))
            self._loaded_ns = self.now_ns()
            self._idle_status_t = -math.inf
        except ParameterError as exc:
            self.diagnose(DiagnosticStatus.ERROR, f'protocol goal rejected: {exc}')
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    async def _execute(self, goal_handle: Any) -> RunProtocol.Result:
        self._goal = goal_handle
        self._goal_done = Future()
        core = self.runner.core
        assert core is not None
        while not self._goal_done.done():
            if goal_handle.is_cancel_requested:
                self.runner.cancel()
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
        fut = self._tick_waiter
        if fut is not None and not fut.done():
            fut.set_result(True)

    def check_tuning(self, new: SequencerSettings, names: list[str]) -> str:
        """New suspenders must parse, and may not replace ones that hold the run."""
        if 'suspenders_yaml' not in names:
            return ''
        if self.runner.suspenders.suspended:
            return 'a suspender holds the run: change the suspenders once it has resumed'
        try:
            suspenders_of(new.suspenders_yaml)
        except PamBenchError as exc:
            return str(exc)
        return ''

    def on_tuned(self, old: SequencerSettings, names: list[str]) -> None:
        """The runner takes the new status period, stale timeout and suspenders."""
        self.runner.retune(self.settings)

    def on_fault(self, reason: str) -> None:
        """Abort: the next tick vents the valve."""
        self.runner.fault(reason)
        self.diagnose(DiagnosticStatus.ERROR, f'protocol aborted: {reason}')


def main(args: list[str] | None = None) -> None:
    """Run the node."""
    run_node(SequencerNode, args)


if __name__ == '__main__':
    main()
