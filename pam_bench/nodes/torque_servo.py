"""torque_servo: 004's torque servo over topics (``TorqueServoController``).

Reads only measured topics: ``load_cell_N/force`` and ``encoder/joint_state``; the set point
comes from the parameters (sine, square or constant, as in the 004 tests) or, once one arrives,
from ``torque_servo/setpoint`` (TorqueSetpoint; its rates are taken as zero). Writes
``valve_N/command`` and ``torque_servo/state`` every control period. With ``muscles = 1`` it is
the single-muscle force check (set point in N).

Safety: a set point beyond +-max_torque is clamped (warned once per excursion); a NaN or inf set
point is rejected (the last valid one is kept); a measured force that is not finite, or (without
lock-step) a measured topic older than ``stale_timeout_s``, vents both valves (0 V) and says why
in the state's ``status``; in lock-step until fresh finite data arrive, on a wall clock (with
``latch_faults``) until ``torque_servo/reset`` (std_srvs/Trigger) is called with fresh data:
a device that comes back does not restart the servo by itself.

On a wall clock (``lockstep: false``) the control loop runs every ``control_period_s`` of the
node's clock on a monotonic deadline (``runtime.process.deadline_spin``); the valves stay vented
and the set point's time stays at zero until every measured topic has arrived, and with
``duration_s`` > 0 the node exits (code 0) that long after its first control step. Its period
statistics are in ``stats_file`` (``analysis.timing``).
"""

from __future__ import annotations

import functools
import math
from typing import Any

from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import WrenchStamped
from pam_bench_interfaces.msg import TorqueServoState, TorqueSetpoint, ValveCommand
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger

from pam_bench.config import topics
from pam_bench.config.settings import TorqueServoSettings
from pam_bench.control.inverse import InverseModel
from pam_bench.control.plugins import PluginFault
from pam_bench.control.torque_servo import (
    Signal,
    SignalKind,
    TorqueServoController,
)
from pam_bench.runtime.base import RELIABLE, SENSOR, BenchNode, Spin
from pam_bench.runtime.messages import ns_of, time_of
from pam_bench.runtime.process import run_node
from pam_bench.runtime.stamped import joint_position, stamped
from pam_bench.sim.lockstep import StopRequest

ABORTED = 4
"""Exit code of a run its servo ended (a controller plug-in that failed), as an aborted
protocol's (``protocol.runner.END_CODES``)."""

__all__ = ['TorqueServoNode', 'main']


class TorqueServoNode(BenchNode):
    """Thin node over ``TorqueServoController``."""

    SETTINGS = TorqueServoSettings

    def __init__(self, name: str = 'torque_servo', **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        s: TorqueServoSettings = self.settings
        self.muscles = s.muscles
        mode, model_file = s.controller, s.inverse_model_file
        self.signal = self._signal(s)
        self.latched = ''
        params = s.servo
        inverse = InverseModel.load(model_file) if model_file else None
        self.ctl = TorqueServoController(params, mode, inverse, self.muscles,
                                         getattr(s.plugins, mode, None))
        chans = range(1, self.muscles + 1)
        self.cell_topics = [topics.load_cell_force(i) for i in chans]
        self.enc_topic = topics.ENCODER
        self.forces = [0.0] * self.muscles
        self.angle_rad = 0.0
        self.stamps: dict[str, float] = {}
        self.external: float | None = None
        self.t0_ns: int | None = None
        self.status = ''
        self._clamped = False
        self.valve_pubs = [self.create_step_publisher(ValveCommand, topics.valve_command(i))
                           for i in chans]
        self.state_pub = self.create_step_publisher(TorqueServoState, topics.SERVO_STATE)
        self.create_subscription(TorqueSetpoint, topics.SERVO_SETPOINT, self._on_setpoint,
                                 RELIABLE)
        if not self.lockstep:
            self.create_service(Trigger, topics.SERVO_RESET, self._on_reset)
        if self.lockstep:
            for tp in self.cell_topics:
                self.sync_input(WrenchStamped, tp)
            self.sync_input(JointState, self.enc_topic)
            self.start_lockstep()
        else:
            for tp in [*self.cell_topics, self.enc_topic]:
                self.create_subscription(
                    JointState if tp == self.enc_topic else WrenchStamped, tp,
                    functools.partial(self._measured, tp), SENSOR)
            self._last_tick_ns: int | None = None
            self._next_progress_ns = 0
            self.start_wall_ticks(self.settings.control_period_s)

    @staticmethod
    def _signal(s: TorqueServoSettings) -> Signal:
        return Signal(SignalKind(s.signal), s.amplitude, s.omega_rad_s, s.offset, s.period_s)

    def on_tuned(self, old: TorqueServoSettings, names: list[str]) -> None:
        """Take a new set-point signal and PID gains between two control steps (the stale
        timeout is read at every step)."""
        self.signal = self._signal(self.settings)
        self.ctl.retune(self.settings.servo)

    def spin_mode(self) -> Spin:
        """In lock-step the node has subscriptions only: it spins on them (a fraction of
        rclpy's executor per message); on a wall clock its loop runs on a monotonic deadline,
        or on rclpy's timer and executor with ``wall_loop: timer`` (to compare)."""
        if not self.lockstep and self.settings.wall_loop == 'timer':
            return Spin.EXECUTOR
        return super().spin_mode()

    # --- inputs ---------------------------------------------------------------------------
    def _on_setpoint(self, msg: TorqueSetpoint) -> None:
        if not self.finite(msg.torque):
            self.reject('torque set point (last valid kept)', msg.torque)
            return
        self.external = float(msg.torque)

    def _measured(self, topic: str, msg: Any) -> None:
        self.stamps[topic] = ns_of(msg.header.stamp) * 1e-9
        self._update(topic, msg)

    def _update(self, topic: str, msg: Any) -> None:
        """Take a measurement (the encoder's joint by name); one that is missing or not finite
        is rejected (counted on /diagnostics) and vents the valves at the next tick, as a
        non-finite measurement does: never an exception in a callback."""
        if topic == self.enc_topic:
            value = joint_position(msg, self.settings.joint_name)
            if not math.isfinite(value):
                self.reject(f'encoder joint {self.settings.joint_name!r} missing or not '
                            'finite', value)
            self.angle_rad = value
        else:
            try:
                force = float(msg.wrench.force.x)
            except (AttributeError, TypeError, ValueError):
                force = math.nan
            if not math.isfinite(force):
                self.reject(f'{topic} force not finite', force)
            self.forces[self.cell_topics.index(topic)] = force

    # --- ticking --------------------------------------------------------------------------
    def on_step(self, t_ns: int, dt_s: float, inputs: dict[str, Any]) -> None:
        """Lock-step tick: the measurements of t_(k-1) -> both valve voltages at t_k."""
        for topic, msg in inputs.items():
            self._update(topic, msg)
        self._tick(t_ns, dt_s, '')

    def on_wall_tick(self, t_ns: int | None = None) -> None:
        """Wall-clock control step: vent while a measured topic is stale (or has never come),
        else control over the time since the last step."""
        t_ns = self.now_ns() if t_ns is None else t_ns
        self.count_tick()
        waiting = len(self.stamps) < len(self.cell_topics) + 1    # not every device is up yet
        if self.t0_ns is None and self.settings.await_recorder and \
                not self.recorder_listens(topics.SERVO_STATE):         # nor the recorder
            waiting = not self.waited_too_long(t_ns, ['a recorder on torque_servo/state'],
                                               self.settings.startup_timeout_s)
        if waiting:
            stamp = time_of(t_ns)
            for pub in self.valve_pubs:
                msg = ValveCommand(voltage=0.0)
                msg.header.stamp = stamp
                pub.publish(msg)
            self.waited_too_long(t_ns, [tp for tp in [*self.cell_topics, self.enc_topic]
                                        if tp not in self.stamps], self.settings.startup_timeout_s)
            return
        if self.t0_ns is not None and self.settings.duration_s > 0.0 and \
                t_ns - self.t0_ns >= round(self.settings.duration_s * 1e9):
            self.exit_code = 0
        if self.t0_ns is not None and t_ns >= self._next_progress_ns:
            self._next_progress_ns = t_ns + 2_000_000_000
            self.get_logger().info(f'[wall] torque_servo: {(t_ns - self.t0_ns) * 1e-9:.0f} s '
                                   f'of {self.settings.duration_s:.0f} s')
        dt = 0.0 if self._last_tick_ns is None else (t_ns - self._last_tick_ns) * 1e-9
        self._last_tick_ns = t_ns
        stale = ''
        for tp in [*self.cell_topics, self.enc_topic]:
            age = t_ns * 1e-9 - self.stamps.get(tp, -math.inf)
            if age > self.settings.stale_timeout_s:
                stale = f'measured topic {tp} stale ({age:.3f} s old): valves vented'
                break
        self._tick(t_ns, dt, stale)

    def _setpoint(self, t_s: float) -> tuple[float, float, float]:
        if self.external is not None:
            s = (self.external, 0.0, 0.0)
        else:
            s = self.signal.value_and_rates(t_s)
        if self.muscles == 2:
            m, clamped = self.ctl.clamp_torque(s[0])
            if clamped and not self._clamped:
                self.diagnose(DiagnosticStatus.WARN, f'torque set point {s[0]:.3f} N m beyond '
                              f'+-{self.ctl.p.max_torque_nm} N m: clamped')
            self._clamped = clamped
            s = (m, 0.0 if clamped else s[1], 0.0 if clamped else s[2])
        return s

    def _on_reset(self, request: Trigger.Request, response: Trigger.Response
                  ) -> Trigger.Response:
        """Clear a latched fault: control resumes at the next tick if the data are fresh."""
        response.success = bool(self.latched)
        response.message = (f'cleared: {self.latched}' if self.latched else 'no latched fault')
        if self.latched:
            self.diagnose(DiagnosticStatus.OK, f'fault cleared by reset: {self.latched}')
        self.latched = ''
        return response

    def _tick(self, t_ns: int, dt_s: float, fault: str) -> None:
        if self.t0_ns is None:
            self.t0_ns = t_ns
        t = (t_ns - self.t0_ns) * 1e-9
        if not fault and not self.finite(self.angle_rad, *self.forces):
            fault = 'measured force or angle not finite: valves vented'
        if fault and self.settings.latch_faults and not self.lockstep:
            self.latched = self.latched or fault
        if not fault and self.latched:
            fault = f'{self.latched} (latched: call {topics.SERVO_RESET} to resume)'
        sp = self._setpoint(t)
        pad = [0.0] * (2 - self.muscles)
        fields: dict[str, Any] = {}
        ch = None
        if not fault:
            try:
                ch = self.ctl.step(dt_s, sp, self.angle_rad, tuple(self.forces))
            except PluginFault as exc:      # a lab's controller: vent, say which, end the run
                fault = f'{exc}: valves vented, run aborted'
                self.latched = self.latched or fault
                self._abort(fault)
        if fault or ch is None:
            if fault != self.status:
                self.diagnose(DiagnosticStatus.ERROR, fault)
            self.ctl.reset()
            volts = [0.0] * self.muscles
        else:
            if self.status:
                self.diagnose(DiagnosticStatus.OK, 'measurements fresh again: control resumed')
            volts = [c.voltage_v for c in ch]
            fields = {'force_setpoint': [c.force_setpoint_n for c in ch] + pad,
                      'contraction': [c.contraction_m for c in ch] + pad,
                      'u_feedforward': [c.u_feedforward_v for c in ch] + pad,
                      'u_pid': [c.u_pid_v for c in ch] + pad}
        self.status = fault
        for pub, u in zip(self.valve_pubs, volts, strict=True):
            pub.publish(stamped(ValveCommand, t_ns, voltage=float(u)))
        f = self.forces + pad
        st = stamped(TorqueServoState, t_ns, controller=self.ctl.name,
                     angle=self.angle_rad, torque_setpoint=float(sp[0]),
                     torque_measured=(self.ctl.r * (f[0] - f[1]) if self.muscles == 2
                                      else float(f[0])),
                     force_measured=[float(v) for v in f],
                     voltage=[float(v) for v in volts] + pad, status=fault, **fields)
        self.state_pub.publish(st)

    def _abort(self, reason: str) -> None:
        """End the run as aborted (exit code ``ABORTED``): in lock-step through the clock,
        which stops after this exchange, on a wall clock by leaving the node's loop."""
        if self.stop_request is None and getattr(self, 'exit_code', None) is None:
            if self.lockstep:
                self.stop_request = StopRequest(ABORTED, f'torque servo: {reason}')
            else:
                self.exit_code = ABORTED

    def on_fault(self, reason: str) -> None:
        """Vent both valves."""
        self.safe_state()

    def safe_state(self) -> None:
        """Vent both valves: a 0 V command on each, now."""
        stamp = time_of(self.stepping.last_ns or 0)
        for pub in self.valve_pubs:
            msg = ValveCommand(voltage=0.0)
            msg.header.stamp = stamp
            pub.publish(msg)


def main(args: list[str] | None = None) -> None:
    """Run the node."""
    run_node(TorqueServoNode, args)


if __name__ == '__main__':
    main()

