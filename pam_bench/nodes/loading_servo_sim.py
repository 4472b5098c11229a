"""loading_servo_sim: the electric loading servo, gear, belt and pulley (``LoadingServoModel``).

Inputs: ``loading_servo/command`` (LoadCommand, previous exchange) and
``sim/muscle_N/samples`` (same exchange: the force at every sub-step). The muscle node has
solved its force together with the drive law this node published for the exchange
(``sim/pulley/law``); the drive replays the same sub-steps with those forces, reaching the
state the muscle assumed, then takes the new command and publishes the law for the next
exchange. A set value therefore acts one exchange after it is sent (the sequencer asks for a
short exchange then). Outputs:
``sim/pulley/state`` (joints ``pulley`` rad and ``muscle_N`` contraction m),
``loading_servo/state`` (joint ``motor``: motor-side angle, rate, torque) and the law. The
drive's force loop reads the muscle force at every sub-step (noise-free: the load cell's noise
is on the recorded readings), its position loop its own 16-bit encoder count. A command that
is not finite, has an unknown mode or a set value out of range is rejected and the last valid
one is kept; a saturated drive is reported on /diagnostics. ``initial_mode`` and
``initial_setpoint`` hold a load from t_0 for scenes without a sequencer (set ``sync_command``
false there).

With ``muscles = 2`` (the torque servo of 004 section 3.2) the drive holds the pulley angle
``hold_angle_rad`` against two antagonistic muscles without simulated mechanics (ideal hold,
as 004's tests use the drive): muscle 1 sits at x1 = x0 + r theta + F1 / k_b, muscle 2 at
x2 = x0 - r theta + F2 / k_b (the law's ``hold_contraction``), the holding torque r (F1 - F2)
goes out as the motor effort.

On a wall clock (``lockstep: false``) its control loop steps at ``rate_hz`` (1 kHz) with the
latest command and the latest muscle force held over its own sub-steps.
"""

from __future__ import annotations

import math
from typing import Any

from diagnostic_msgs.msg import DiagnosticStatus
from pam_bench_interfaces.msg import DriveLaw, LoadCommand, MuscleSamples
from sensor_msgs.msg import JointState

from pam_bench.config import topics
from pam_bench.config.settings import LoadingServoSettings
from pam_bench.models.constants import SUB_STEP_S
from pam_bench.models.coupling import substep_grid
from pam_bench.models.loading_servo import LoadingServoModel, LoadMode, law_of
from pam_bench.runtime.base import RELIABLE, BenchNode
from pam_bench.runtime.process import run_node
from pam_bench.runtime.stamped import stamped

__all__ = ['LoadingServoSim', 'main']


class LoadingServoSim(BenchNode):
    """Thin node over ``LoadingServoModel``."""

    SETTINGS = LoadingServoSettings

    def __init__(self, name: str = 'loading_servo', **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        s: LoadingServoSettings = self.settings
        self.channel = s.channel
        self.sync_command = s.sync_command
        self.muscles = s.muscles
        self.hold_angle_rad = s.hold_angle_rad
        self.rest_contraction_m = s.rest_contraction_m
        init_mode, init_sp = s.initial_mode, s.initial_setpoint
        self.model = LoadingServoModel(s.servo)
        if init_mode:
            self.model.command(LoadMode(init_mode), init_sp)
            if init_mode == LoadMode.POSITION:
                self.model.reset(init_sp)
        ch = self.channel
        self.cmd_topic = topics.LOAD_COMMAND
        self.muscle_topics = ([topics.muscle_samples(i) for i in (1, 2)]
                              if self.muscles == 2 else [topics.muscle_samples(ch)])
        self._was_saturated = False
        self._touches = 0                       # torque-limit touches since the last report
        self._last_report = -math.inf       # node clock, s, of that report
        self._reported = 'within'           # what it said last: within, moving, holding
        self.pulley_pub = self.create_step_publisher(JointState, topics.PULLEY_STATE)
        self.state_pub = self.create_step_publisher(JointState, topics.LOAD_STATE)
        self.law_pub = self.create_step_publisher(DriveLaw, topics.PULLEY_LAW)
        if self.sync_command and self.lockstep:
            self.sync_input(LoadCommand, self.cmd_topic)
        else:
            self.create_subscription(LoadCommand, self.cmd_topic, self.apply_command, RELIABLE)
        for topic in self.muscle_topics:
            self.sync_input(MuscleSamples, topic, same_step=True)
        self.start_stepping()

    def apply_command(self, msg: LoadCommand) -> None:
        """Accept a valid mode and set value, else keep the last valid command."""
        sp = msg.setpoint
        p = self.model.p
        ok = msg.mode in (LoadCommand.MODE_OFF, LoadCommand.MODE_FORCE,
                          LoadCommand.MODE_POSITION) and self.finite(sp)
        if ok and msg.mode == LoadCommand.MODE_FORCE:
            ok = 0.0 <= sp <= p.force_limit_n
        if ok and msg.mode == LoadCommand.MODE_POSITION:
            ok = p.travel_min_m <= sp <= p.travel_max_m
        if not ok:
            self.reject('loading servo command (last valid kept)', (msg.mode, sp))
            return
        if (LoadMode(msg.mode), sp) != (self.model.mode, self.model.setpoint):
            self.model.command(LoadMode(msg.mode), sp)

    def wall_inputs(self, inputs: dict[str, Any], dt_s: float) -> dict[str, Any]:
        """The latest muscle force held over this step's own sub-steps."""
        for topic in self.muscle_topics:
            m: MuscleSamples = inputs[topic]
            steps = substep_grid(dt_s, SUB_STEP_S)
            inputs[topic] = MuscleSamples(step=steps, force=[m.force[-1]] * len(steps),
                                          contraction=[m.contraction[-1]] * len(steps))
        return inputs

    def on_start(self, t_ns: int) -> None:
        """Publish the law of the first exchange."""
        self._publish_law(t_ns)

    SATURATION_REPORT_S = 1.0
    """Seconds of the node's clock (sim time in lock-step, so a bag is the same at any speed)
    between two reports of the torque limit (the drive touches it many times a second while
    it holds a force against a pulling muscle)."""
    MOVE_TOLERANCE_M = 0.5e-3
    """A position-mode drive farther than this from its set value is moving to it: at its
    torque limit it accelerates as hard as it can, which is no fault."""

    def _saturation(self, t_ns: int, saturated: bool, contraction_m: float) -> None:
        """Report the torque limit as it is now: WARN while the drive holds a set value at its
        limit (a muscle pulling harder than the drive can hold), OK while it only moves to a
        new set value at full torque, OK once it is within its limit; one diagnostic per
        ``SATURATION_REPORT_S`` at most, with the touches since the last, and a change that
        came too soon reported as soon as the period allows (never left stale)."""
        if saturated and not self._was_saturated:
            self._touches += 1
        self._was_saturated = saturated
        moving = (self.model.mode == LoadMode.POSITION
                  and abs(self.model.setpoint - contraction_m) > self.MOVE_TOLERANCE_M)
        kind = 'holding' if saturated and not moving else 'moving' if saturated else 'within'
        if kind == self._reported:
            return
        now = t_ns * 1e-9
        if now - self._last_report < self.SATURATION_REPORT_S:
            return
        self._last_report, self._reported = now, kind
        if kind == 'holding':
            self.diagnose(DiagnosticStatus.WARN, 'loading servo at its torque limit while it '
                          f'holds its set value ({self._touches} touch(es) since the last '
                          'report)', touches=self._touches)
        elif kind == 'moving':
            self.diagnose(DiagnosticStatus.OK, 'loading servo moving to its set value at its '
                          'torque limit', touches=self._touches)
        else:
            self.diagnose(DiagnosticStatus.OK, 'loading servo within its torque limit')
        self._touches = 0

    def on_step(self, t_ns: int, dt_s: float, inputs: dict[str, Any]) -> None:
        """Replay the muscle's sub-steps, take the command, publish the next law."""
        i, r = self.model.p.gear_ratio, self.model.r
        if self.muscles == 2:
            states = [inputs[t] for t in self.muscle_topics]
            th = self._pair_angle()
            f1, f2 = states[0].force[-1], states[1].force[-1]
            positions = [th, states[0].contraction[-1], states[1].contraction[-1]]
            names = ['pulley', 'muscle_1', 'muscle_2']
            velocity = [0.0, 0.0, 0.0]
            motor: dict[str, Any] = dict(name=[topics.MOTOR_JOINT], position=[th * i],
                                         velocity=[0.0], effort=[r * (f1 - f2) / i])
        else:
            m: MuscleSamples = inputs[self.muscle_topics[0]]
            out = self.model.replay(list(m.step), list(m.force))
            if out.saturated or self._reported != 'within':
                self._saturation(t_ns, out.saturated, out.contraction_m)
            positions = [out.pulley_angle_rad, out.contraction_m]
            names = ['pulley', f'muscle_{self.channel}']
            velocity = [out.pulley_rate_rad_s, out.pulley_rate_rad_s * r]
            motor = dict(name=[topics.MOTOR_JOINT], position=[self.model.phi * i],
                         velocity=[out.pulley_rate_rad_s * i], effort=[out.output_torque_nm / i])
        if self.cmd_topic in inputs:
            self.apply_command(inputs[self.cmd_topic])
        self.pulley_pub.publish(stamped(JointState, t_ns, name=names, position=positions,
                                        velocity=velocity))
        self.state_pub.publish(stamped(JointState, t_ns, **motor))
        self._publish_law(t_ns)

    def _pair_angle(self) -> float:
        return (self.model.setpoint / self.model.r if self.model.mode == LoadMode.POSITION
                else self.hold_angle_rad)

    def _publish_law(self, t_ns: int) -> None:
        law = stamped(DriveLaw, t_ns, mode=int(self.model.mode), setpoint=self.model.setpoint,
                      belt_stiffness=self.model.p.belt_stiffness_n_per_m)
        if self.muscles == 2:
            x0, rth = self.rest_contraction_m, self.model.r * self._pair_angle()
            law.hold_contraction = [x0 + rth, x0 - rth]
        else:
            law.parameters, law.state = law_of(self.model)
        self.law_pub.publish(law)

    def safe_state(self) -> None:
        """Torque off."""
        self.model.command(LoadMode.OFF, 0.0)

    def on_fault(self, reason: str) -> None:
        """Torque off."""
        self.safe_state()


def main(args: list[str] | None = None) -> None:
    """Run the node."""
    run_node(LoadingServoSim, args)


if __name__ == '__main__':
    main()
