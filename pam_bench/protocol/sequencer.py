"""The sequencer state machine over a protocol schedule (pure: no ROS, no wall clock).

The ``Sequencer`` walks a list of ``schedules.Reading``; it is ticked with the sim time and
the latest measurements and returns the commands to send and, at the end of each dwell, the
point (and, after a step, the force record collected by stamp).
"""

from __future__ import annotations

import enum
import math

from pam_bench.models.loading_servo import LoadMode
from pam_bench.protocol.io import Commands, Measurement, Point, RecordWindow, StepRecord
from pam_bench.protocol.schedules import Reading
from pam_bench.protocol.settings import COMMAND_STEP_S, RECORD_EXCHANGE_S, Limits
from pam_bench.protocol.window import SampleWindow
from pam_bench.vocabulary.errors import ParameterError

__all__ = ['Phase', 'Measurement', 'Limits', 'Point', 'StepRecord', 'Commands', 'Sequencer',
           'COMMAND_STEP_S', 'RECORD_EXCHANGE_S']

_EPS = 1e-9                 # s: a phase ends at its scheduled time within this


class Phase(enum.Enum):
    """Phase of the sequencer."""

    IDLE = 'idle'
    SETTLE = 'settle'
    LEAD = 'lead'
    DWELL = 'dwell'
    RECORD = 'record'
    PAUSED = 'paused'
    DONE = 'done'
    ABORTED = 'aborted'
    CANCELLED = 'cancelled'


class Sequencer:
    """State machine over a schedule. ``tick`` is called at every sim-time step.

    Per reading: optional LEAD (extra settling after a change of protocol), DWELL (set values
    applied, ``dwell_s``), then either the reading, or for a step-response reading the step of
    u and a RECORD of the force every ``sample_period_s`` for ``record_s``. The run starts
    with SETTLE at the first reading's set values. Safety: the run aborts, venting the valve,
    when the load cell reaches its range, or when at a reading the loading servo is off its set
    value by more than the tolerance.

    Record samples are the load-cell readings passed to ``tick`` with their stamps; sample i is
    the one stamped t_step + i T. Samples may arrive after the window (a bench that delivers
    them late): the schedule goes on at the end of the window and the record is handed out
    (``Commands.record``) once its last sample is in. During a record the sequencer asks the
    valve for samples every T (``Commands.sample_period_s``: a simulated valve then reports
    its pressure, and the load cell its force, at every sample) and a lock-step clock for
    exchange steps of at most ``record_exchange_s`` (0: the whole record in one exchange).
    ``start_index`` resumes a run at that reading (``resume_index``, ``with_approach``): the
    settle phase then holds that reading's set values. A reading that is not ``recorded`` (an
    approach step) is held and checked like any other but gives no point. A reading's force
    and contraction are the means of the samples of its last ``window_s`` inside ``bands``
    (input -> (low, high); ``protocol.window``); the limits are checked on those means.
    """

    def __init__(self, name: str, readings: list[Reading], settle_s: float,
                 limits: Limits | None = None, record_exchange_s: float = 0.0,
                 start_index: int = 0,
                 bands: dict[str, tuple[float, float]] | None = None) -> None:
        if not readings:
            raise ParameterError(f'protocol {name!r} has no readings')
        if not 0 <= start_index < len(readings):
            raise ParameterError(f'protocol {name!r}: cannot resume at reading {start_index} of '
                                 f'{len(readings)}')
        self.start_index = start_index
        self.name = name
        self.readings = readings
        self.settle_s = settle_s
        self.limits = limits or Limits()
        self.phase = Phase.IDLE
        self.index = 0
        self.t_phase = 0.0
        self.t_start = 0.0
        self.reason = ''
        self.points_done = 0
        self.record_exchange_s = record_exchange_s
        self.rec: RecordWindow | None = None          # the record of the current window
        self.pending: RecordWindow | None = None      # a record past its window, samples to come
        self._total = settle_s + sum(r.lead_s + r.dwell_s + r.record_s
                                     for r in readings[start_index:])
        self._total_points = sum(r.recorded for r in readings)
        self.paused_s = 0.0                      # time spent paused so far, s
        self._pause_request: tuple[str, bool] | None = None
        self._resume_request = False
        self._paused: tuple[str, bool, Phase, float] = ('', False, Phase.IDLE, 0.0)
        self.bands = dict(bands or {})
        keep = max((r.window_s for r in readings), default=0.0) + 0.1
        self.windows = {'force': SampleWindow(keep), 'contraction': SampleWindow(keep)}

    @property
    def total_points(self) -> int:
        """Readings the run records (approach steps of a resumed run are not)."""
        return self._total_points

    @property
    def total_s(self) -> float:
        """Scheduled sim time of the whole run, s."""
        return self._total

    @property
    def running(self) -> bool:
        """True while the protocol is in progress, paused included (or a record still waits
        for samples)."""
        return (self.phase in (Phase.SETTLE, Phase.LEAD, Phase.DWELL, Phase.RECORD,
                               Phase.PAUSED)
                or (self.phase == Phase.DONE and self.pending is not None))

    def pause(self, reason: str = 'paused', vent: bool = False) -> None:
        """Pause at the next safe point: at once while settling or dwelling (the reading is
        dwelt again from its start on resume), after the record during a record. Held: the
        reading's set values stay commanded; vented (``vent``): 0 V and the drive off, and
        the resume settles again before the dwell. A pause requested while paused only
        updates the reason."""
        if self.running:
            self._pause_request = (reason, vent)

    def resume(self) -> None:
        """End a pause (or cancel a pause not yet taken) at the next tick."""
        self._pause_request = None
        self._resume_request = self.phase == Phase.PAUSED

    @property
    def pause_reason(self) -> str:
        """Why the run is paused ('' when it is not)."""
        return self._paused[0] if self.phase == Phase.PAUSED and self._paused else ''

    def _pause_or_resume(self, t_s: float) -> None:
        """Take a requested pause at a safe point, or end a pause."""
        if self._pause_request is not None and self.phase == Phase.PAUSED:
            self._paused = (self._pause_request[0], self._paused[1] or self._pause_request[1],
                            self._paused[2], self._paused[3])
            self._pause_request = None
        elif self._pause_request is not None and self.phase in (Phase.SETTLE, Phase.LEAD,
                                                                 Phase.DWELL):
            reason, vent = self._pause_request
            self._paused = (reason, vent, self.phase, t_s)
            self._pause_request = None
            self.phase, self.t_phase = Phase.PAUSED, t_s
        elif self._resume_request and self.phase == Phase.PAUSED:
            _, vent, was, t_pause = self._paused
            self.paused_s += t_s - t_pause
            self._resume_request = False
            back = Phase.SETTLE if vent or was == Phase.SETTLE else Phase.DWELL
            self.phase, self.t_phase = back, t_s

    def remaining_s(self, t_s: float) -> float:
        """Scheduled sim time still to run, s."""
        if self.phase == Phase.IDLE:
            return self.total_s
        if not self.running:
            return 0.0
        paused = self.paused_s + (t_s - self._paused[3] if self.phase == Phase.PAUSED else 0.0)
        return max(self.total_s - (t_s - self.t_start - paused), 0.0)

    def start(self, t_s: float) -> None:
        """Begin with the settle phase at the first reading's set values."""
        self.phase, self.t_phase, self.t_start = Phase.SETTLE, t_s, t_s
        self.index = self.points_done = self.start_index
        self.rec = self.pending = None
        self.reason = ''

    def stop(self, phase: Phase, reason: str) -> None:
        """End early (ABORTED or CANCELLED) with a reason."""
        if self.running or self.phase == Phase.IDLE:
            self.phase, self.reason = phase, reason
            self.rec = self.pending = None

    def next_event_s(self, t_s: float) -> float:
        """Sim time of the next phase change or record sample (inf when idle or ended)."""
        if not self.running:
            return float('inf')
        if self.phase == Phase.DONE:                # waiting for the last record's samples
            return t_s + (self.record_exchange_s or 1e-3)
        if self.phase == Phase.PAUSED:
            return float('inf')
        if self.phase == Phase.SETTLE:
            return self.t_phase + self.settle_s
        r = self.readings[self.index]
        if self.phase == Phase.LEAD:
            return self.t_phase + r.lead_s
        if self.phase == Phase.DWELL:
            return self.t_phase + r.dwell_s
        step = self.record_exchange_s or r.record_s
        return min(t_s + step, self.t_phase + r.record_s)

    def _voltage(self, r: Reading, t_s: float) -> float:
        if self.phase == Phase.RECORD or r.pre_voltage_v is None:
            if r.ramp_from_v is None or self.phase != Phase.DWELL:
                return r.voltage_v
            a = min(max((t_s - self.t_phase) / r.dwell_s, 0.0), 1.0)
            return r.ramp_from_v + (r.voltage_v - r.ramp_from_v) * a
        return r.pre_voltage_v

    def _check(self, r: Reading, meas: Measurement) -> str:
        lim = self.limits
        if abs(meas.force_n) >= 0.999 * lim.force_range_n:
            return f'load cell out of range: {meas.force_n:.1f} N'
        if r.load_mode == LoadMode.FORCE:
            tol = lim.force_tolerance_n + lim.force_tolerance_rel * abs(r.load_value)
            if abs(meas.force_n - r.load_value) > tol:
                return (f'loading servo cannot reach {r.load_value:.1f} N '
                        f'(measured {meas.force_n:.1f} N)')
        if lim.pressure_tolerance_pa > 0.0 and r.ramp_from_v is None:
            want = lim.valve_gain_pa_per_v * r.voltage_v
            if abs(meas.pressure_pa - want) > lim.pressure_tolerance_pa:
                return (f'valve does not follow: {meas.pressure_pa / 1e3:.1f} kPa at '
                        f'{r.voltage_v:.2f} V (expected {want / 1e3:.1f} kPa)')
        if r.load_mode == LoadMode.POSITION and r.record_s == 0.0:
            if abs(meas.contraction_m - r.load_value) > lim.position_tolerance_m:
                return (f'loading servo cannot reach x = {r.load_value * 1e3:.2f} mm '
                        f'(measured {meas.contraction_m * 1e3:.2f} mm)')
        return ''

    def tick(self, t_s: float, meas: Measurement,
             samples: list[tuple[float, float]] | None = None,
             contraction_samples: list[tuple[float, float]] | None = None) -> Commands:
        """Advance to ``t_s`` given the latest measurement and the load-cell samples (stamp s,
        force N) received since the last tick (None: the latest force, stamped ``t_s``), and
        likewise the encoder's contraction samples (stamp s, m); return what to command.

        One tick runs the phases in order, each possibly handing over to the next at the same
        time: samples into the open records, a pause taken or ended (``pause``), SETTLE ->
        LEAD/DWELL, LEAD -> DWELL, DWELL -> a reading or RECORD, RECORD -> its reading; then
        the commands of the phase reached.
        """
        if samples is None:
            samples = [(t_s, meas.force_n)]
        if contraction_samples is None:
            contraction_samples = [(t_s, meas.contraction_m)]
        self.windows['force'].add(samples)
        self.windows['contraction'].add(contraction_samples)
        if self.running and abs(meas.force_n) >= 0.999 * self.limits.force_range_n:
            self.stop(Phase.ABORTED, f'load cell out of range: {meas.force_n:.1f} N')
        record = self._collect(samples)
        self._pause_or_resume(t_s)
        if self.phase == Phase.SETTLE:
            self._settle(t_s)
        point = None
        if self.phase == Phase.LEAD:
            self._lead(t_s)
        elif self.phase == Phase.DWELL:
            point = self._dwell(t_s, meas, samples)
        if self.phase == Phase.RECORD:
            point, finished = self._record(t_s, meas)
            record = finished or record
        return self._commands(t_s, point, record)

    def _collect(self, samples: list[tuple[float, float]]) -> StepRecord | None:
        """Put the samples into the open records; hand out a pending record now complete."""
        for rec in (self.pending, self.rec):
            if rec is not None:
                rec.add_many(samples)
        if self.pending is not None and self.pending.complete:
            done, self.pending = self.pending.finished(), None
            return done
        return None

    def _settle(self, t_s: float) -> None:
        if t_s - self.t_phase >= self.settle_s - _EPS:
            self.phase, self.t_phase = Phase.DWELL, t_s
            if self.readings[self.index].lead_s > 0 and self.index > self.start_index:
                self.phase = Phase.LEAD

    def _lead(self, t_s: float) -> None:
        if t_s - self.t_phase >= self.readings[self.index].lead_s - _EPS:
            self.phase, self.t_phase = Phase.DWELL, t_s

    def _dwell(self, t_s: float, meas: Measurement, samples: list[tuple[float, float]]
               ) -> Point | None:
        r = self.readings[self.index]
        if t_s - self.t_phase < r.dwell_s - _EPS:
            return None
        if r.record_s <= 0.0:
            return self._take(r, t_s, meas)
        self.phase, self.t_phase = Phase.RECORD, t_s
        self.rec = RecordWindow(r, t_s)
        self.rec.add_many(samples)              # the sample at t_step may be in already
        return None

    def _record(self, t_s: float, meas: Measurement) -> tuple[Point | None, StepRecord | None]:
        r = self.readings[self.index]
        if t_s - self.t_phase < r.record_s - _EPS or self.rec is None:
            return None, None
        rec, self.rec = self.rec, None
        rec.point = point = self._take(r, t_s, meas)
        if point is None:
            return None, None
        if rec.complete:
            return point, rec.finished()
        self.pending = rec
        return point, None

    def _commands(self, t_s: float, point: Point | None, record: StepRecord | None
                  ) -> Commands:
        if self.running and self.phase != Phase.DONE:
            r = self.readings[self.index]
            if self.phase == Phase.PAUSED and self._paused[1]:
                return Commands(0.0, LoadMode.OFF, 0.0, point, record)   # vented
            if self.phase in (Phase.SETTLE, Phase.PAUSED):
                u0 = r.ramp_from_v if r.ramp_from_v is not None else (
                    r.pre_voltage_v if r.pre_voltage_v is not None else r.voltage_v)
                return Commands(u0, r.load_mode, r.load_value, point, record)
            period = r.sample_period_s if self.phase == Phase.RECORD else 0.0
            return Commands(self._voltage(r, t_s), r.load_mode, r.load_value, point, record,
                            period)
        last = self.readings[min(self.index, len(self.readings) - 1)]
        if self.phase == Phase.DONE:
            return Commands(0.0, last.load_mode, last.load_value, point, record)
        return Commands(0.0, LoadMode.OFF, 0.0, point, record)          # vent, torque off

    def _take(self, r: Reading, t_s: float, meas: Measurement) -> Point | None:
        n = 1
        outliers: tuple[tuple[str, float, float], ...] = ()
        if r.window_s > 0.0:
            inf = (-math.inf, math.inf)
            f = self.windows['force'].average(t_s, r.window_s, meas.force_n,
                                              self.bands.get('force', inf))
            x = self.windows['contraction'].average(t_s, r.window_s, meas.contraction_m,
                                                    self.bands.get('contraction', inf))
            meas = Measurement(f.value, x.value, meas.pressure_pa)
            n = max(f.n, 1)
            outliers = tuple(('force', t, v) for t, v in f.outliers) + \
                tuple(('contraction', t, v) for t, v in x.outliers)
        problem = self._check(r, meas)
        if problem:
            self.stop(Phase.ABORTED, problem)
            return None
        point = Point(r, t_s, r.voltage_v, meas, n, outliers) if r.recorded else None
        self.points_done += r.recorded
        self.index += 1
        self.t_phase = t_s
        if self.index >= len(self.readings):
            self.phase = Phase.DONE
        else:
            self.phase = Phase.LEAD if self.readings[self.index].lead_s > 0 else Phase.DWELL
        return point
