"""The torque servo's bench: two antagonistic muscles on one pulley whose angle the drive holds.

004 section 3.2: muscle 1 and muscle 2 pull on the two sides of the pulley (radius r = 31.83 mm),
and the drive holds the angle theta, so each muscle sits at its own contraction

    x_1 = x_0 + r theta + F_1 / k_b,    x_2 = x_0 - r theta + F_2 / k_b

(x_0 the rest contraction at theta = 0, m; k_b the belt stiffness, N/m), the drive taking the
torque tau = r (F_1 - F_2) N m at the pulley. The hold is ideal (``IdealHold``: no drive
mechanics), as the lock-step nodes run the scene (``loading_servo_sim`` with ``muscles: 2``)
and as the twin's servo loop does (``twin.servo_bench.run_servo``). Each exchange of h s, per
muscle i, as ``twin.bench.SingleMuscleBench`` does for one:

    p_j       = valve_i.samples(u_i, sub-steps of h, V_i)       (exact ZOH, 004 section 2.1)
    F_j, x_j  = coupling.solve_substeps(muscle_i, hold_i, sub-steps, p_j)
    F_m,i     = load_cell_i.measure(F_i),   theta_m = encoder.measure(theta)

A load command in position mode moves the held angle to theta = x* / r (the set value is the
contraction r theta, as ``loading_servo_sim`` reads it); any other mode keeps the angle the
scene holds (``hold_angle_rad``). The drive the CAN bus serves (``twin.cia402_drive``) reads
``servo.phi`` (rad) and ``servo.torque`` (N m) from here.
"""

from __future__ import annotations

import dataclasses

from pam_bench.models.bench_muscle import BenchMuscle
from pam_bench.models.constants import SUB_STEP_S
from pam_bench.models.coupling import SettleParams, solve_substeps, substep_grid
from pam_bench.models.loading_servo import IdealHold, LoadingServoParams, LoadMode
from pam_bench.models.sensors import EncoderModel, EncoderParams, LoadCellModel, LoadCellParams
from pam_bench.models.valve import ValveModel, ValveParams

__all__ = ['HeldPulley', 'PairBench']


@dataclasses.dataclass
class HeldPulley:
    """The drive holding the pulley of a pair (module docstring): the angle phi rad, the torque
    it takes N m, and the angle a command other than a position leaves it at."""

    radius_m: float
    hold_angle_rad: float
    phi: float = 0.0
    torque: float = 0.0

    def __post_init__(self) -> None:
        self.phi = self.hold_angle_rad

    def command(self, mode: LoadMode, setpoint: float) -> None:
        """Position mode: hold theta = set value / r; otherwise the scene's hold angle."""
        self.phi = (setpoint / self.radius_m if LoadMode(mode) == LoadMode.POSITION
                    else self.hold_angle_rad)

    @property
    def angle(self) -> float:
        """The pulley angle, rad (the encoder's)."""
        return self.phi


class PairBench:
    """Two valves, two muscles, two load cells and the encoder on a held pulley (module
    docstring), stepped exchange by exchange on the models the nodes run.

    Args:
        valves: each muscle's valve.
        muscles: each muscle (``models.bench_muscle.make_muscle``: a McKibben, the
            straight-fibre muscle or a law), reset here to its held end.
        load_cells: each muscle's load cell, its noise seeded by ``seeds``.
        encoder: the pulley's encoder.
        servo: the drive (its pulley radius and belt stiffness).
        hold_angle_rad: the angle held until a position command, rad.
        rest_contraction_m: x_0, both muscles' contraction at theta = 0, m.
        sub_step_s: the longest sub-step inside an exchange, s.
    """

    def __init__(self, valves: tuple[ValveParams, ValveParams],
                 muscles: tuple[BenchMuscle, BenchMuscle],
                 load_cells: tuple[LoadCellParams, LoadCellParams],
                 encoder: EncoderParams | None = None, servo: LoadingServoParams | None = None,
                 hold_angle_rad: float = 0.0, rest_contraction_m: float = 0.04,
                 seeds: tuple[int, int] = (0, 1),
                 sub_step_s: float = SUB_STEP_S, settle: SettleParams | None = None) -> None:
        sp = servo or LoadingServoParams()
        self.sub_step_s = sub_step_s
        self.settle = settle or SettleParams()
        self.k_b = sp.belt_stiffness_n_per_m
        self.x0 = rest_contraction_m
        self.servo = HeldPulley(sp.pitch_diameter_m / 2.0, hold_angle_rad)
        self.valves = [ValveModel(v) for v in valves]
        self.muscles = list(muscles)
        self.cells = [LoadCellModel(c, seed=s) for c, s in zip(load_cells, seeds, strict=True)]
        self.encoder = EncoderModel(encoder)
        self.u = [0.0, 0.0]
        self.p = [0.0, 0.0]
        self.f = [0.0, 0.0]
        self.f_meas = [0.0, 0.0]
        self.th_meas = 0.0
        for m, x in zip(self.muscles, self._ends(), strict=True):
            m.reset(x, 0.0)
        self.volume = [m.volume(0.0) for m in self.muscles]
        self.t = 0.0

    def _ends(self) -> tuple[float, float]:
        """x_0 + r theta and x_0 - r theta, m: where the hold puts each muscle's end."""
        rth = self.servo.radius_m * self.servo.phi
        return self.x0 + rth, self.x0 - rth

    def command_valve(self, voltage_v: float, channel: int = 1) -> None:
        """Hold ``voltage_v`` on valve ``channel`` (1 or 2) from now on."""
        self.u[channel - 1] = voltage_v

    def command_load(self, mode: LoadMode, setpoint: float, now: bool = False) -> None:
        """The drive's command (module docstring); it acts from the next exchange."""
        self.servo.command(mode, setpoint)

    def step(self, h_s: float) -> None:
        """One exchange of ``h_s`` seconds (module docstring)."""
        steps = substep_grid(h_s, min(self.sub_step_s, h_s))
        for i, x0 in enumerate(self._ends()):
            pressures = self.valves[i].samples(self.u[i], steps, self.volume[i])
            res = solve_substeps(self.muscles[i], IdealHold(x0, self.k_b), steps, pressures,
                                 self.f[i], self.settle)
            self.p[i], self.f[i] = pressures[-1], res.forces_n[-1]
            self.volume[i] = self.muscles[i].volume(res.contractions_m[-1])
            self.f_meas[i] = self.cells[i].measure(self.f[i])
        self.servo.torque = self.servo.radius_m * (self.f[0] - self.f[1])
        self.th_meas, _ = self.encoder.measure(self.servo.angle, h_s)
        self.t += h_s

    def signals(self) -> dict[str, float]:
        """What the DAQ measures, by register-map signal: pressures gauge Pa, forces N, angle
        rad."""
        return {'valve_1.pressure': self.p[0], 'valve_2.pressure': self.p[1],
                'load_cell_1.force': self.f_meas[0], 'load_cell_2.force': self.f_meas[1],
                'encoder.angle': self.th_meas}
