"""The single-muscle bench coupled in one process with numpy, exchange for exchange as the nodes.

Each exchange step [t_k-1, t_k] of length h, in the nodes' order (``runtime.base``: a chain of
same-exchange inputs valve -> muscle -> loading servo -> encoder, muscle -> load cell):

    valve:   p_j     = valve.samples(u, sub-steps of h, V_k-1)    (exact ZOH, u and V held)
    muscle:  F_j, x_j = coupling.solve_substeps(muscle, drive law of t_k-1, sub-steps, p_j)
             (a settled muscle held for the rest of the exchange: ``settle``)
    servo:   the drive keeps the same sub-steps (the node replays F_j), then takes the command
             the sequencer sent at t_k-1: a new set value acts one exchange after it is sent
    cell:    F_m     = load_cell.measure(F_n)  (every F_j during a 1 kHz record)
    encoder: theta_m = encoder.measure(theta_n)

The sub-steps are ``sub_step_s`` long from the start of the exchange (the last one shorter when
h is not a multiple), or the record's sample period while one is asked for
(``step(h, sample_period_s=T)``). The mechanics inside an exchange are solved implicitly at
every sub-step (``models.coupling``), so the exchange step only decides how often the devices
talk, not how the muscle and the drive move; what an exchange still delays is a new servo set
value and the chamber volume the valve sees.

It is the reference the ROS runs are compared against and the engine of the calibration.
"""

from __future__ import annotations

import dataclasses
from typing import Any

from pam_bench.models.bench_muscle import make_muscle
from pam_bench.models.constants import SUB_STEP_S
from pam_bench.models.coupling import SettleParams, solve_substeps, substep_grid
from pam_bench.models.loading_servo import LoadingServoModel, LoadingServoParams, LoadMode
from pam_bench.models.muscle import MuscleParams
from pam_bench.models.sensors import EncoderModel, EncoderParams, LoadCellModel, LoadCellParams
from pam_bench.models.straight_fibre_muscle import StraightFibreParams
from pam_bench.models.valve import ValveModel, ValveParams, VolumeEvidence
from pam_bench.protocol.sequencer import COMMAND_STEP_S

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
                 sub_step_s: float = SUB_STEP_S,
                 straight_fibre: StraightFibreParams | None = None,
                 settle: SettleParams | None = None, laws: Any = None) -> None:
        self.sub_step_s = sub_step_s
        self.settle = settle or SettleParams()
        self.valve = ValveModel(valve)
        self.muscle = make_muscle(muscle, straight_fibre, laws)
        self.cell = LoadCellModel(load_cell, seed=seed)
        self.encoder = EncoderModel(encoder)
        self.servo = LoadingServoModel(servo)
        self.t = 0.0
        self.u = 0.0
        self.p = 0.0
        self.f = 0.0
        self.x = 0.0
        self.volume = self.muscle.volume(0.0)
        self.evidence = VolumeEvidence()   # what the valve node knows of the volume
        self._u_applied: float | None = None
        self._request = 0.0
        self.f_meas = 0.0
        self.th_meas = 0.0
        self.steps = 0                # exchanges taken
        self.substeps = 0             # sub-steps taken
        self.held = 0                 # of them, sub-steps that held a settled muscle
        self._pending: tuple[LoadMode, float] | None = None
        self.samples: list[tuple[float, float]] = []   # (t s, measured N) of the last step

    def command_valve(self, voltage_v: float, channel: int = 1) -> None:
        """Hold ``voltage_v`` on the valve from now on (``channel``: a bench of one muscle has
        valve 1 only; another channel's command has no valve to reach)."""
        if channel == 1:
            self.u = voltage_v

    def signals(self) -> dict[str, float]:
        """What a DAQ measures, by register-map signal: gauge pressure Pa, force N, angle
        rad."""
        return {'valve_1.pressure': self.p, 'load_cell_1.force': self.f_meas,
                'encoder.angle': self.th_meas}

    def command_load(self, mode: LoadMode, setpoint: float, now: bool = False) -> None:
        """Loading servo mode and set value (N or m): acts after the next exchange, as a
        command sent at this tick reaches the drive's law one exchange later (``now``: at
        once, for setting a bench up)."""
        if now:
            self.servo.command(mode, setpoint)
            self._pending = None
        else:
            self._pending = (LoadMode(mode), setpoint)

    def step(self, h_s: float, sample_period_s: float = 0.0) -> BenchState:
        """One exchange step of ``h_s`` seconds (module docstring); ``sample_period_s`` > 0
        fills ``samples`` with the load cell at every sub-step of that length."""
        # the valve node at the end of this exchange: the command and the volume report of its
        # start (nodes.valve_sim)
        if self._u_applied is not None and self.u != self._u_applied:
            self.evidence.command_changed(self.t)
        self._u_applied = self.u
        self.evidence.volume(self.t, self.volume)
        period = sample_period_s if sample_period_s > 0.0 else self.sub_step_s
        steps = substep_grid(h_s, min(period, h_s))
        pressures = self.valve.samples(self.u, steps, self.volume)
        res = solve_substeps(self.muscle, self.servo, steps, pressures, self.f, self.settle)
        self.substeps += len(steps)
        self.held += res.held
        self.steps += 1
        if self._pending is not None:
            self.servo.command(*self._pending)
            self._pending = None
        self.p, self.f, self.x = pressures[-1], res.forces_n[-1], res.contractions_m[-1]
        self._request = self.valve.max_step(self.u, self.evidence)
        self.volume = self.muscle.volume(self.x)
        if sample_period_s > 0.0:
            t, stamps = self.t, []
            for d in steps:
                t += d
                stamps.append(t)
            measured, _ = self.cell.measure_many(res.forces_n)
            self.samples = list(zip(stamps, measured.tolist(), strict=True))
            self.f_meas = self.samples[-1][1]
        else:
            self.f_meas = self.cell.measure(self.f)
            self.samples = [(self.t + h_s, self.f_meas)]
        self.th_meas, _ = self.encoder.measure(self.servo.angle, h_s)
        self.t += h_s
        return BenchState(self.t, self.u, self.p, self.f, self.x, self.f_meas, self.th_meas,
                          self.servo.torque)

    def run(self, duration_s: float, h_s: float, first_s: float | None = None) -> BenchState:
        """Step for ``duration_s`` in exchanges of at most ``h_s`` and return the last state
        (the last exchange ends exactly at ``duration_s``), shorter when a device asks
        (``max_step``, as the ROS sim clock takes the requests of the acknowledgements).
        ``first_s`` > 0: the first exchange is that short, as the sequencer asks after a new
        set value (None: ``COMMAND_STEP_S`` when a load command waits, so it acts after 1 ms
        as in a protocol run, else none)."""
        st = None
        t_end = self.t + duration_s
        if first_s is None:
            first_s = COMMAND_STEP_S if self._pending is not None else 0.0
        if first_s > 0.0:
            st = self.step(min(first_s, duration_s))
        while st is None or self.t < t_end - 1e-9:
            h = h_s
            req = self.max_step()
            if req > 0.0:
                h = min(h, req)
            st = self.step(min(h, max(t_end - self.t, 1e-9)))
        return st

    def max_step(self) -> float:
        """Longest next exchange step the devices ask for, s (0: any)."""
        return self._request
