"""loading_servo_sim: the electric loading servo, gear, belt and pulley (``LoadingServoModel``).

Inputs: ``loading_servo/command`` (LoadCommand), ``sim/muscle_N/state`` (tension, stiffness),
``load_cell_N/force`` and ``encoder/joint_state`` (what the drive's PID reads). Outputs:
``sim/pulley/state`` (joints ``pulley`` rad and ``muscle_N`` contraction m) and
``loading_servo/state`` (joint ``motor``: motor-side angle, rate, torque). A command that is not
finite, has an unknown mode or a set value out of range is rejected and the last valid one is
kept; a saturated drive is reported on /diagnostics.
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
        self.model = LoadingServoModel(self.declare_model('servo', LoadingServoParams))
        ch = self.channel
        self.cmd_topic = 'loading_servo/command'
        self.muscle_topic = f'sim/muscle_{ch}/state'
        self.cell_topic = f'load_cell_{ch}/force'
        self.enc_topic = 'encoder/joint_state'
        self.muscle = MuscleState()
        self.f_meas = 0.0
        self.th_meas = 0.0
        self._was_saturated = False
        self.pulley_pub = self.create_publisher(JointState, 'sim/pulley/state', RELIABLE)
        self.state_pub = self.create_publisher(JointState, 'loading_servo/state', RELIABLE)
        if self.sync_command:
            self.sync_input(LoadCommand, self.cmd_topic)
        else:
            self.create_subscription(LoadCommand, self.cmd_topic, self.apply_command, RELIABLE)
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

    def on_fault(self, reason: str) -> None:
        """Torque off."""
        self.model.command(LoadMode.OFF, 0.0)


def main(args: list[str] | None = None) -> None:
    """Run the node."""
    run_node(LoadingServoSim, args)


if __name__ == '__main__':
    main()
