"""A protocol run on the numpy bench, tick for tick as the lock-step nodes run it.

The sequencer's own state machine (``protocol.sequencer.Sequencer``) drives the numpy bench
(``twin.bench.SingleMuscleBench``) with the exchange steps the ROS sim clock would take: the
scene's longest step, cut by the sequencer's requests (the next reading, ``command_step_s`` at
every new reading or phase, at most ``record_exchange_s`` in a record) and by the valve's
(``ValveModel.max_step``). At every tick the devices advance over the exchange on the commands
of the previous tick, then the sequencer reads the measurements of this tick and commands the
next exchange, as the node chain does. The same scene therefore gives the same readings as its
ROS run, up to the sensor noise, which does not feed back (the drive's loop reads the true
force). With a short ``exchange_step_s`` it is the reference the scenes' long exchanges are
measured against.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from typing import Any

from pam_bench.config.protocols import protocol_schedule
from pam_bench.models.constants import SUB_STEP_S
from pam_bench.models.loading_servo import LoadingServoParams
from pam_bench.models.muscle import MuscleParams
from pam_bench.models.sensors import LoadCellParams
from pam_bench.models.straight_fibre_muscle import StraightFibreParams
from pam_bench.models.valve import ValveParams
from pam_bench.protocol.schedules import Reading
from pam_bench.protocol.sequencer import (
    COMMAND_STEP_S,
    RECORD_EXCHANGE_S,
    Measurement,
    Phase,
    Point,
    Sequencer,
    StepRecord,
)
from pam_bench.sim.lockstep import EventStepRequest, negotiate
from pam_bench.twin.bench import SingleMuscleBench

__all__ = ['TwinRun', 'run_readings', 'run_protocol']


@dataclasses.dataclass
class TwinRun:
    """Points and step records of a run, its exchanges and sub-steps, wall time (s)."""

    points: list[Point]
    records: list[StepRecord]
    exchanges: int
    substeps: int
    sim_s: float
    wall_s: float


def run_readings(name: str, readings: list[Reading], settle_s: float, exchange_step_s: float,
                 sub_step_s: float = SUB_STEP_S, valve: ValveParams | None = None,
                 muscle: MuscleParams | None = None, servo: LoadingServoParams | None = None,
                 load_cell: LoadCellParams | None = None, seed: int = 0,
                 command_step_s: float = COMMAND_STEP_S,
                 record_exchange_s: float = RECORD_EXCHANGE_S,
                 events: Sequence[tuple[float, str]] = (),
                 straight_fibre: StraightFibreParams | None = None) -> TwinRun:
    """Run a schedule to its end (module docstring); the bench starts at rest. ``events``:
    (sim time s, 'pause' | 'pause_vent' | 'resume'), given to the sequencer at the first tick
    at or after that time, as an operator's service call would be."""
    bench = SingleMuscleBench(valve=valve, muscle=muscle, load_cell=load_cell, servo=servo,
                              seed=seed, sub_step_s=sub_step_s, straight_fibre=straight_fibre)
    seq = Sequencer(name, readings, settle_s, record_exchange_s=record_exchange_s)
    seq.start(0.0)
    points: list[Point] = []
    records: list[StepRecord] = []
    h = command_step_s                      # the sequencer asks for it at t_0
    sample_period = 0.0
    request = EventStepRequest(command_step_s)
    t0 = time.perf_counter()
    pending = sorted(events)
    while True:
        if pending and seq.phase == Phase.PAUSED:   # land on the next event, not beyond it
            h = min(h, max(pending[0][0] - bench.t, command_step_s))
        bench.step(h, sample_period)
        meas = Measurement(bench.f_meas, bench.th_meas * bench.servo.r, bench.p)
        while pending and bench.t >= pending[0][0] - 1e-12:
            what = pending.pop(0)[1]
            if what == 'resume':
                seq.resume()
            else:
                seq.pause('operator', vent=what == 'pause_vent')
        cmd = seq.tick(bench.t, meas, list(bench.samples))
        if cmd.point is not None:
            points.append(cmd.point)
        if cmd.record is not None:
            records.append(cmd.record)
        if not seq.running:
            break
        bench.command_valve(cmd.voltage_v)
        bench.command_load(cmd.load_mode, cmd.load_value)
        sample_period = cmd.sample_period_s
        # the requests the sequencer and the valve put in their acknowledgements
        h = negotiate(exchange_step_s, (request.request(bench.t, seq.next_event_s(bench.t),
                                                        (seq.index, seq.phase)),
                                        bench.max_step()))
    return TwinRun(points, records, bench.steps, bench.substeps, bench.t,
                   time.perf_counter() - t0)


def run_protocol(protocol: str, exchange_step_s: float, table: dict[str, Any] | None = None,
                 overrides: dict[str, Any] | None = None, **kw: Any) -> TwinRun:
    """Run a protocol of config/protocols.yaml (or of ``table``) with ``run_readings``."""
    readings, settle = protocol_schedule(protocol, overrides, table)
    return run_readings(protocol, readings, settle, exchange_step_s, **kw)
