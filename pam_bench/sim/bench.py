"""The single-muscle bench coupled in one process with numpy, exchange for exchange as the nodes.

Each exchange step of length h, exactly as the lock-step ROS nodes do. ``coupling='jacobi'``:
every device sees the others' outputs of the previous exchange:

    valve:   p_k+1      = valve.step(u_k, h, V_k)
    muscle:  F, K, V    = muscle.step(p_k, x_k)          (algebraic, friction state)
    cell:    F_m        = load_cell.measure(F_k)
    encoder: theta_m    = encoder.measure(theta_k)
    servo:   theta, x   = servo.step(h, F_k, K_k, x_e,k, F_m,k, theta_m,k)

``coupling='chained'`` (Gauss-Seidel along valve -> muscle -> load cell, the nodes' ``chained``
parameter): the muscle takes the pressure of the same exchange and the load cell the force of
the same exchange, so the open chain from the valve command to the load cell has no exchange
delay; the loading servo and the encoder still see the previous exchange:

    muscle:  F_k+1      = muscle.step(p_k+1, x_k),   cell: F_m,k+1 = load_cell.measure(F_k+1)

With a sample period T (``step(h, sample_period_s=T)``, chained only) the valve integrates the
exchange in h / T sub-steps and the muscle and the load cell follow every sub-step: the force
at each sample time, as the nodes publish it during a 1 kHz record taken with exchange steps
much longer than 1 ms. Between exchanges the muscle end yields with the holder's compliance c
(belt 1 / k_b plus the drive's position loop 1 / K_px, 1e-6 m/N):
x_j = x_k + c (F_j - F_k) (``MuscleModel.step_compliant``).

It is the reference the ROS runs are compared against and the engine of the calibration.
"""

from __future__ import annotations

import dataclasses

from pam_bench.models.loading_servo import LoadingServoModel, LoadingServoParams, LoadMode
from pam_bench.models.muscle import MuscleModel, MuscleParams
from pam_bench.models.sensors import EncoderModel, EncoderParams, LoadCellModel, LoadCellParams
from pam_bench.models.valve import ValveModel, ValveParams, sub_steps

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
                 servo: LoadingServoParams | None = None, seed: int = 0,
                 coupling: str = 'jacobi', holder_compliance_m_per_n: float = 1.0e-6) -> None:
        if coupling not in ('jacobi', 'chained'):
            raise ValueError(f'coupling {coupling!r}: use jacobi or chained')
        self.coupling = coupling
        self.compliance = holder_compliance_m_per_n
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
        self.samples: list[tuple[float, float]] = []   # (t s, measured N) of the last step

    def command_valve(self, voltage_v: float) -> None:
        """Hold ``voltage_v`` from now on."""
        self.u = voltage_v

    def command_load(self, mode: LoadMode, setpoint: float) -> None:
        """Loading servo mode and set value (N or m)."""
        self.servo.command(mode, setpoint)

    def step(self, h_s: float, sample_period_s: float = 0.0) -> BenchState:
        """One exchange step of ``h_s`` seconds (module docstring); ``sample_period_s`` > 0
        (chained coupling) fills ``samples`` with the load cell at every sub-step."""
        if self.coupling == 'jacobi':
            p_new = self.valve.step(self.u, h_s, self.out.volume_m3)
            out_new = self.muscle.step(self.p, self.x)
            f_meas_new = self.cell.measure(self.out.force_n)
            self.samples = [(self.t + h_s, f_meas_new)]
        else:
            n = sub_steps(h_s, sample_period_s)
            self.samples = []
            c = self.compliance if n > 1 else 0.0
            x_eval = self.x
            for j in range(1, n + 1):
                p_new = self.valve.step(self.u, h_s / n, self.out.volume_m3)
                out_new, x_eval = self.muscle.step_compliant(p_new, self.x, self.out.force_n, c)
                f_meas_new = self.cell.measure(out_new.force_n)
                self.samples.append((self.t + h_s * j / n, f_meas_new))
        th_meas_new, _ = self.encoder.measure(self.theta, h_s)
        srv = self.servo.step(h_s, self.out.force_n, self.out.stiffness_n_per_m, self.x_eval,
                              self.f_meas, self.th_meas)
        self.p, self.out, self.f_meas, self.th_meas = p_new, out_new, f_meas_new, th_meas_new
        self.x_eval = self.x if self.coupling == 'jacobi' else x_eval
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
