"""loading_servo_sim: the electric loading servo, gear, belt and pulley (``LoadingServoModel``).

Inputs: ``loading_servo/command`` (LoadCommand), ``sim/muscle_N/state`` (tension, stiffness),
``load_cell_N/force`` and ``encoder/joint_state`` (what the drive's PID reads). Outputs:
``sim/pulley/state`` (joints ``pulley`` rad and ``muscle_N`` contraction m) and
``loading_servo/state`` (joint ``motor``: motor-side angle, rate, torque). A command that is not
finite, has an unknown mode or a set value out of range is rejected and the last valid one is
kept; a saturated drive is reported on /diagnostics. ``initial_mode`` and ``initial_setpoint``
hold a load from t_0 for scenes without a sequencer (set ``sync_command`` false there).

With ``muscles = 2`` (the torque servo of 004 section 3.2) the drive holds the pulley angle
``hold_angle_rad`` against two antagonistic muscles and the drive mechanics are not simulated
(ideal position hold, as 004's tests use the drive): muscle 1 sits at
x1 = x0 + r theta + F1 / k_b, muscle 2 at x2 = x0 - r theta + F2 / k_b (belt stretch from the
last forces), the holding torque r (F1 - F2) goes out as the motor effort.
"""

from __future__ import annotations

from typing import Any

from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import WrenchStamped
from pam_bench_interfaces.msg import LoadCommand, MuscleState
from sensor_msgs.msg import JointState

from pam_bench.models.loading_servo import LoadingServoModel, LoadingServoParams, LoadMode
from pam_bench.nodes.base import RELIABLE, BenchNode, run_node, time_of

__all__ = ['LoadingServoSim', 'main']


class LoadingServoSim(BenchNode):
    """Thin node over ``LoadingServoModel``."""

    LEAN_SPIN = True    # subscriptions only: see nodes.base.lean_spin

    def __init__(self, name: str = 'loading_servo', **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        self.channel = self.declare_typed('channel', 1, 'muscle channel on the belt', '-', 1, 2)
        self.sync_command = self.declare_typed(
            'sync_command', True, 'require a command at every step (lock-step controllers)')
        self.muscles = self.declare_typed('muscles', 1, 'muscles on the belt: 1 '
                                          '(characterisation) or 2 (antagonistic pair, angle '
                                          'held)', '-', 1, 2)
        self.hold_angle_rad = self.declare_typed('hold_angle_rad', 0.0, 'pulley angle held '
                                                 'with two muscles', 'rad', -1.0472, 1.0472)
        self.rest_contraction_m = self.declare_typed(
            'rest_contraction_m', 0.04, 'contraction x0 of both muscles at theta = 0 (two '
            'muscles)', 'm', 0.0, 0.15)
        init_mode = self.declare_typed('initial_mode', 0, 'LoadCommand mode held until the '
                                       'first command: 0 off, 1 force, 2 position', '-', 0, 2)
        init_sp = self.declare_typed('initial_setpoint', 0.0, 'set value of initial_mode (N or '
                                     'm)', '', -10.0, 1e4)
        self.model = LoadingServoModel(self.declare_model('servo', LoadingServoParams))
        if init_mode:
            self.model.command(LoadMode(init_mode), init_sp)
            if init_mode == LoadMode.POSITION:
                self.model.reset(init_sp)
        ch = self.channel
        self.cmd_topic = 'loading_servo/command'
        self.muscle_topic = f'sim/muscle_{ch}/state'
        self.cell_topic = f'load_cell_{ch}/force'
        self.enc_topic = 'encoder/joint_state'
        self.muscle = MuscleState()
        self.f_meas = 0.0
        self.th_meas = 0.0
        self._was_saturated = False
        self.pulley_pub = self.create_step_publisher(JointState, 'sim/pulley/state')
        self.state_pub = self.create_step_publisher(JointState, 'loading_servo/state')
        if self.sync_command:
            self.sync_input(LoadCommand, self.cmd_topic)
        else:
            self.create_subscription(LoadCommand, self.cmd_topic, self.apply_command, RELIABLE)
        if self.muscles == 2:
            self.pair = [MuscleState(), MuscleState()]
            for i in (1, 2):
                self.sync_input(MuscleState, f'sim/muscle_{i}/state')
        else:
            self.sync_input(MuscleState, self.muscle_topic)
            self.sync_input(WrenchStamped, self.cell_topic)
            self.sync_input(JointState, self.enc_topic)
        self.start_lockstep()

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

    def on_step(self, t_ns: int, dt_s: float, inputs: dict[str, Any]) -> None:
        """Advance the drive mechanics over the exchange step."""
        if self.muscles == 2:
            self._hold_pair(t_ns, inputs)
            return
        if inputs:
            if self.cmd_topic in inputs:
                self.apply_command(inputs[self.cmd_topic])
            self.muscle = inputs[self.muscle_topic]
            self.f_meas = inputs[self.cell_topic].wrench.force.x
            js = inputs[self.enc_topic]
            self.th_meas = js.position[0]
        m = self.muscle
        out = self.model.step(dt_s, m.force, m.stiffness, m.contraction, self.f_meas,
                              self.th_meas)
        self.max_next_step_s = self.model.max_step()
        if out.saturated != self._was_saturated:
            self._was_saturated = out.saturated
            self.diagnose(DiagnosticStatus.WARN if out.saturated else DiagnosticStatus.OK,
                          'loading servo ' + ('at its torque limit' if out.saturated
                                              else 'within its torque limit'))
        stamp = time_of(t_ns)
        r, i = self.model.r, self.model.p.gear_ratio
        pulley = JointState(name=['pulley', f'muscle_{self.channel}'],
                            position=[out.pulley_angle_rad, out.contraction_m],
                            velocity=[out.pulley_rate_rad_s, out.pulley_rate_rad_s * r])
        pulley.header.stamp = stamp
        self.pulley_pub.publish(pulley)
        motor = JointState(name=['motor'], position=[float(self.model.state[0]) * i],
                           velocity=[out.pulley_rate_rad_s * i],
                           effort=[out.output_torque_nm / i])
        motor.header.stamp = stamp
        self.state_pub.publish(motor)

    def _hold_pair(self, t_ns: int, inputs: dict[str, Any]) -> None:
        """Two muscles, ideal angle hold (module docstring)."""
        if self.cmd_topic in inputs:
            self.apply_command(inputs[self.cmd_topic])
        for i in (0, 1):
            topic = f'sim/muscle_{i + 1}/state'
            if topic in inputs:
                self.pair[i] = inputs[topic]
        r, k_b = self.model.r, self.model.p.belt_stiffness_n_per_m
        th = (self.model.setpoint / r if self.model.mode == LoadMode.POSITION
              else self.hold_angle_rad)
        f1, f2 = self.pair[0].force, self.pair[1].force
        x1 = self.rest_contraction_m + r * th + f1 / k_b
        x2 = self.rest_contraction_m - r * th + f2 / k_b
        stamp = time_of(t_ns)
        pulley = JointState(name=['pulley', 'muscle_1', 'muscle_2'], position=[th, x1, x2],
                            velocity=[0.0, 0.0, 0.0])
        pulley.header.stamp = stamp
        self.pulley_pub.publish(pulley)
        i = self.model.p.gear_ratio
        motor = JointState(name=['motor'], position=[th * i], velocity=[0.0],
                           effort=[r * (f1 - f2) / i])
        motor.header.stamp = stamp
        self.state_pub.publish(motor)

    def on_fault(self, reason: str) -> None:
        """Torque off."""
        self.model.command(LoadMode.OFF, 0.0)


def main(args: list[str] | None = None) -> None:
    """Run the node."""
    run_node(LoadingServoSim, args)


if __name__ == '__main__':
    main()
