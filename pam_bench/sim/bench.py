"""The single-muscle bench coupled in one process with numpy, exchange for exchange as the nodes.

Each exchange step of length h (Jacobi co-simulation, every device sees the others' outputs of
the previous exchange, exactly as the lock-step ROS nodes do):

    valve:   p_k+1      = valve.step(u_k, h, V_k)
    muscle:  F, K, V    = muscle.step(p_k, x_k)          (algebraic, friction state)
    cell:    F_m        = load_cell.measure(F_k)
    encoder: theta_m    = encoder.measure(theta_k)
    servo:   theta, x   = servo.step(h, F_k, K_k, x_e,k, F_m,k, theta_m,k)

It is the reference the ROS runs are compared against and the engine of the calibration.
"""

from __future__ import annotations

import dataclasses

from pam_bench.models.loading_servo import LoadingServoModel, LoadingServoParams, LoadMode
from pam_bench.models.muscle import MuscleModel, MuscleParams
from pam_bench.models.sensors import EncoderModel, EncoderParams, LoadCellModel, LoadCellParams
from pam_bench.models.valve import ValveModel, ValveParams

__all__ = ['BenchState', 'SingleMuscleBench']


@dataclasses.dataclass
class BenchState:
    """Signals after one exchange: SI units."""

    t_s: float
    voltage_v: float
    pressure_pa: float
    force_n: float
    contraction_m: float
    measured_force_n: float
    measured_angle_rad: float
    servo_torque_nm: float


class SingleMuscleBench:
    """Valve, muscle, load cell, encoder and loading servo coupled by exchange steps."""

    def __init__(self, valve: ValveParams | None = None, muscle: MuscleParams | None = None,
                 load_cell: LoadCellParams | None = None, encoder: EncoderParams | None = None,
                 servo: LoadingServoParams | None = None, seed: int = 0) -> None:
        self.valve = ValveModel(valve)
        self.muscle = MuscleModel(muscle)
        self.cell = LoadCellModel(load_cell, seed=seed)
        self.encoder = EncoderModel(encoder)
        self.servo = LoadingServoModel(servo)
        self.t = 0.0
        self.u = 0.0
        self.p = 0.0
        self.out = self.muscle.step(0.0, 0.0)
        self.x = 0.0
        self.x_eval = 0.0
        self.theta = 0.0
        self.f_meas = 0.0
        self.th_meas = 0.0
        self.steps = 0                # exchanges taken by adaptive runs

    def command_valve(self, voltage_v: float) -> None:
        """Hold ``voltage_v`` from now on."""
        self.u = voltage_v

    def command_load(self, mode: LoadMode, setpoint: float) -> None:
        """Loading servo mode and set value (N or m)."""
        self.servo.command(mode, setpoint)

    def step(self, h_s: float) -> BenchState:
        """One exchange step of ``h_s`` seconds."""
        p_new = self.valve.step(self.u, h_s, self.out.volume_m3)
        out_new = self.muscle.step(self.p, self.x)
        f_meas_new = self.cell.measure(self.out.force_n)
        th_meas_new, _ = self.encoder.measure(self.theta, h_s)
        srv = self.servo.step(h_s, self.out.force_n, self.out.stiffness_n_per_m, self.x_eval,
                              self.f_meas, self.th_meas)
        self.p, self.out, self.f_meas, self.th_meas = p_new, out_new, f_meas_new, th_meas_new
        self.x_eval = self.x
        self.x, self.theta = srv.contraction_m, srv.pulley_angle_rad
        self.t += h_s
        return BenchState(self.t, self.u, self.p, self.out.force_n, self.x, self.f_meas,
                          self.th_meas, srv.output_torque_nm)

    def max_step(self) -> float:
        """Longest next exchange step the devices ask for, s (0: any)."""
        reqs = [r for r in (self.valve.max_step(self.u), self.servo.max_step()) if r > 0.0]
        return min(reqs) if reqs else 0.0

    def run(self, duration_s: float, h_s: float, adaptive: bool = False) -> BenchState:
        """Step for ``duration_s`` and return the last state.

        With ``adaptive`` the step is ``h_s`` unless a device asks for a shorter one (as the
        ROS sim clock does with the requests in the StepAck), and the run ends exactly at
        ``duration_s``.
        """
        st = None
        if not adaptive:
            for _ in range(max(1, round(duration_s / h_s))):
                st = self.step(h_s)
            return st
        t_end = self.t + duration_s
        while self.t < t_end - 1e-12:
            h = h_s
            req = self.max_step()
            if req > 0.0:
                h = min(h, req)
            h = min(h, t_end - self.t)
            st = self.step(h)
            self.steps += 1
        return st
