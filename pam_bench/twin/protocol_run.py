"""A protocol run on the numpy bench, tick for tick as the lock-step nodes run it.

The protocol runner the sequencer node ticks (``protocol.runner.Runner``: the state machine,
suspenders, pause, the end) drives the numpy bench (``twin.bench.SingleMuscleBench``) with the
exchange steps the ROS sim clock would take: the scene's longest step, cut by the runner's
requests (the next reading, ``command_step_s`` at every new reading or phase, at most
``record_exchange_s`` in a record) and by the valve's (``ValveModel.max_step``). At every tick
the devices advance over the exchange on the commands of the previous tick, then the runner
reads the measurements of this tick and commands the next exchange, as the node chain does.
The same scene therefore gives the same readings as its ROS run, up to the sensor noise,
which does not feed back (the drive's loop reads the true force). With a short
``exchange_step_s`` it is the reference the scenes' long exchanges are measured against.
``run_scene`` runs a scene from its settings (``config.scene.Scene.settings``), the objects
the nodes are built from.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from pam_bench.bags.bagread import BagData, Points
from pam_bench.bags.bagread import StepRecord as BagRecord
from pam_bench.config.protocols import parse_overrides, protocol_schedule
from pam_bench.config.scene import Scene
from pam_bench.models.constants import SUB_STEP_S
from pam_bench.models.coupling import SettleParams
from pam_bench.models.loading_servo import LoadingServoParams
from pam_bench.models.muscle import MuscleParams
from pam_bench.models.sensors import LoadCellParams
from pam_bench.models.straight_fibre_muscle import StraightFibreParams
from pam_bench.models.valve import ValveParams
from pam_bench.protocol.io import Point, StepRecord
from pam_bench.protocol.runner import END_CODES, Runner
from pam_bench.protocol.schedules import Reading, with_approach
from pam_bench.protocol.sequencer import Phase, Sequencer
from pam_bench.protocol.settings import COMMAND_STEP_S, RECORD_EXCHANGE_S, RunnerSettings
from pam_bench.sim.lockstep import negotiate
from pam_bench.twin.bench import SingleMuscleBench

__all__ = ['TwinRun', 'run_readings', 'run_protocol', 'run_scene', 'TIMED_OUT', 'bag_data_of']

TIMED_OUT = 6
"""Exit code of a twin run stopped at its ``max_sim_s``."""


@dataclasses.dataclass
class TwinRun:
    """Points and step records of a run, its exchanges and sub-steps, wall time (s), and how
    it ended (exit code 0 done, 4 aborted; the runner's reason)."""

    points: list[Point]
    records: list[StepRecord]
    exchanges: int
    substeps: int
    sim_s: float
    wall_s: float
    exit_code: int = 0
    reason: str = ''
    paused_s: float = 0.0          # sim time spent paused or suspended
    suspensions: int = 0           # times a suspender paused the run
    held: int = 0                  # sub-steps that held a settled muscle (of ``substeps``)


def run_readings(name: str, readings: list[Reading], settle_s: float, exchange_step_s: float,
                 sub_step_s: float = SUB_STEP_S, valve: ValveParams | None = None,
                 muscle: MuscleParams | None = None, servo: LoadingServoParams | None = None,
                 load_cell: LoadCellParams | None = None, seed: int = 0,
                 command_step_s: float = COMMAND_STEP_S,
                 record_exchange_s: float = RECORD_EXCHANGE_S,
                 events: Sequence[tuple[float, str]] = (),
                 straight_fibre: StraightFibreParams | None = None,
                 runner: RunnerSettings | None = None, start_index: int = 0,
                 max_sim_s: float = math.inf, settle: SettleParams | None = None) -> TwinRun:
    """Run a schedule to its end (module docstring); the bench starts at rest. ``events``:
    (sim time s, 'pause' | 'pause_vent' | 'resume'), given to the runner at the first tick
    at or after that time, as an operator's service call would be. ``runner``: the runner's
    settings (limits, suspenders, pause action; default: the defaults with these steps).
    ``max_sim_s``: stop there (exit code ``TIMED_OUT``; a run a suspender holds for ever, or
    a job of a sweep, must end). ``settle``: when a settled muscle is held for the rest of an
    exchange (None: the muscle node's default, ``models.coupling.SettleParams``). A force
    law left to ``auto`` runs as a scene of these steps would run it
    (``models.law_muscle.law_core_for``), so the twin's run is the nodes'."""
    if muscle is not None:
        from pam_bench.models.law_muscle import with_law_core
        muscle = with_law_core(muscle, exchange_step_s, sub_step_s)
    bench = SingleMuscleBench(valve=valve, muscle=muscle, load_cell=load_cell, servo=servo,
                              seed=seed, sub_step_s=sub_step_s, straight_fibre=straight_fibre,
                              settle=settle)
    settings = runner or RunnerSettings(command_step_s=command_step_s,
                                        record_exchange_s=record_exchange_s)
    run = Runner(settings, lockstep=True)
    run.load(Sequencer(name, readings, settle_s, run.limits, settings.record_exchange_s,
                       start_index))
    run.start(0.0)
    points: list[Point] = []
    records: list[StepRecord] = []
    h = settings.command_step_s               # the sequencer asks for it at t_0
    sample_period = 0.0
    t0 = time.perf_counter()
    pending = sorted(events)
    suspensions = 0
    core = run.core
    assert core is not None
    while True:
        if pending and core.phase == Phase.PAUSED:
            h = min(h, max(pending[0][0] - bench.t, settings.command_step_s))
        bench.step(h, sample_period)
        t = bench.t
        run.samples_in(list(bench.samples[:-1]))
        run.measured('force', bench.f_meas, t)
        run.measured('contraction', bench.th_meas * bench.servo.r, t)
        run.measured('pressure', bench.p, t)
        while pending and t >= pending[0][0] - 1e-12:
            what = pending.pop(0)[1]
            if what == 'resume':
                run.resume()
            else:
                run.pause('operator', vent=what == 'pause_vent')
        tick = run.tick(t)
        suspensions += sum(n.text.startswith('protocol suspended') for n in tick.notes)
        if tick.point is not None:
            points.append(tick.point)
        if tick.record is not None:
            records.append(tick.record)
        if run.ended:
            break
        if t >= max_sim_s:
            return TwinRun(points, records, bench.steps, bench.substeps, bench.t,
                           time.perf_counter() - t0, TIMED_OUT,
                           f'stopped at {max_sim_s:g} s of sim time', core.paused_s,
                           suspensions, bench.held)
        cmd = tick.commands
        bench.command_valve(cmd.voltage_v)
        bench.command_load(cmd.load_mode, cmd.load_value)
        sample_period = cmd.sample_period_s
        # the requests the sequencer and the valve put in their acknowledgements
        h = negotiate(exchange_step_s, (tick.next_step_s, bench.max_step()))
    return TwinRun(points, records, bench.steps, bench.substeps, bench.t,
                   time.perf_counter() - t0, END_CODES.get(core.phase, 4), core.reason,
                   core.paused_s, suspensions, bench.held)


def run_protocol(protocol: str, exchange_step_s: float, table: dict[str, Any] | None = None,
                 overrides: dict[str, Any] | None = None, **kw: Any) -> TwinRun:
    """Run a protocol of config/protocols.yaml (or of ``table``) with ``run_readings``."""
    readings, settle = protocol_schedule(protocol, overrides, table)
    return run_readings(protocol, readings, settle, exchange_step_s, **kw)


def run_scene(scene: Scene, seed: int = 0, events: Sequence[tuple[float, str]] = ()
              ) -> TwinRun:
    """Run a single-muscle protocol scene on the twin, with every model and runner setting
    from the scene's settings (the objects its nodes are built from)."""
    st = scene.settings(seed=seed)
    seq, muscle = st['sequencer'], st['muscle_1']
    readings, settle = protocol_schedule(seq.protocol,
                                         parse_overrides(seq.protocol_overrides_yaml))
    readings, start = with_approach(readings, seq.resume_from_reading)
    return run_readings(seq.protocol, readings, settle, scene.exchange_step_s,
                        scene.sub_step_s, valve=st['valve_1'].valve, muscle=muscle.muscle,
                        servo=st['loading_servo'].servo, load_cell=st['load_cell_1'].load_cell,
                        seed=st['load_cell_1'].seed, events=events,
                        straight_fibre=muscle.straight_fibre, runner=seq, start_index=start,
                        settle=muscle.settle)


def bag_data_of(run: TwinRun) -> BagData:
    """A twin run's readings and step records as the extraction reads a bag's
    (``bags.bagread``): the same estimators then apply to both."""
    by: dict[str, list[Point]] = {}
    for pt in run.points:
        by.setdefault(pt.reading.protocol, []).append(pt)
    points = {}
    for name, pts in by.items():
        def col(f: Any, pts: list[Point] = pts) -> np.ndarray:
            return np.array([f(p) for p in pts])
        points[name] = Points(name, col(lambda p: p.t_s), col(lambda p: p.reading.series),
                              col(lambda p: p.reading.step),
                              col(lambda p: int(p.reading.direction)),
                              col(lambda p: p.reading.series_value),
                              col(lambda p: p.reading.set_value), col(lambda p: p.voltage_v),
                              col(lambda p: p.measurement.force_n),
                              col(lambda p: p.measurement.contraction_m),
                              col(lambda p: p.measurement.pressure_pa))
    records = [BagRecord(r.reading.series, r.reading.step, int(r.reading.direction),
                         r.reading.load_value, float(r.reading.pre_voltage_v or 0.0),
                         r.reading.voltage_v, r.reading.sample_period_s,
                         np.asarray(r.samples, float)) for r in run.records]
    return BagData(points, records)
