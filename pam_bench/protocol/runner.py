"""The protocol runner: the sequencer state machine with every policy around it, pure.

The sequencer node and the twin tick the same ``Runner``; the node only turns messages into
``measured``/``sample`` calls and a ``Tick`` back into messages. Around
``protocol.sequencer.Sequencer`` the runner decides:

- **start gating** (wall clock): an autostart protocol begins once every measured input
  (force, contraction, pressure, and the loading servo's state: ``drive``) has arrived and
  whatever the node gates on (``gate``: the run's recorder listening) is there; until then
  the commands vent the valve;
- **bad input**: a measurement that is not finite is rejected and aborts a running protocol,
  which vents the valve;
- **stale inputs** (wall clock): an input older than ``stale_timeout_s`` aborts the run,
  unless a suspender watches its staleness (the run then waits, suspended);
- **suspenders** (``protocol.suspenders``): pause the run when an input leaves its band or
  goes stale, resume it when all have held for their ``resume_after_s``;
- **pause and resume** by the operator, held or vented (``pause_action``);
- **the end**: exit code 0 done, 4 aborted, 5 cancelled; in lock-step a ``StopRequest`` to the
  clock, on a wall clock an exit ``end_linger_s`` after the end (the recorder gets the last
  points and status);
- **status timing** (a status at every phase change and every ``status_period_s``) and the
  **exchange step** a lock-step run asks for (``sim.lockstep.EventStepRequest``).

Times are seconds of the runner's clock (sim time in lock-step, the node's clock otherwise).
"""

from __future__ import annotations

import dataclasses
import math

from pam_bench.models.loading_servo import LoadMode
from pam_bench.protocol.io import Commands, Measurement, Point, StepRecord
from pam_bench.protocol.sequencer import Phase, Sequencer
from pam_bench.protocol.settings import RunnerSettings
from pam_bench.protocol.suspenders import INPUTS, Suspenders, parse_rules
from pam_bench.sim.lockstep import EventStepRequest, StopRequest
from pam_bench.vocabulary.yaml_io import load_yaml

__all__ = ['Runner', 'Tick', 'Note', 'END_CODES', 'INPUTS', 'suspenders_of']

END_CODES = {Phase.DONE: 0, Phase.ABORTED: 4, Phase.CANCELLED: 5}
"""Exit code of a run that ended in each phase."""
OK, WARN, ERROR = 'ok', 'warn', 'error'


@dataclasses.dataclass(frozen=True)
class Note:
    """Something to put on /diagnostics: level ('ok', 'warn', 'error') and text."""

    level: str
    text: str


@dataclasses.dataclass
class Tick:
    """What a tick decided: the commands to send (with the point and record taken), whether a
    status is due, notes for /diagnostics, a stop request for the clock (lock-step end), the
    exit code once the node should go (wall-clock end), the next exchange step wanted (s, 0:
    any) and whether the run is still waiting to start (``waiting``: the inputs it lacks)."""

    commands: Commands
    status_due: bool = False
    notes: list[Note] = dataclasses.field(default_factory=list)
    stop: StopRequest | None = None
    exit_code: int | None = None
    next_step_s: float = 0.0
    waiting: list[str] = dataclasses.field(default_factory=list)

    @property
    def point(self) -> Point | None:
        """The reading taken at this tick."""
        return self.commands.point

    @property
    def record(self) -> StepRecord | None:
        """The step record completed at this tick."""
        return self.commands.record


def suspenders_of(text: str) -> Suspenders:
    """The suspenders of a ``suspenders_yaml`` setting.

    Raises:
        ParameterError: not YAML, or a rule that is not one (named).
    """
    return Suspenders(parse_rules(load_yaml(text, 'suspenders') if text else []))


VENTED = Commands(0.0, LoadMode.OFF, 0.0, None)


class Runner:
    """A protocol run with its policies (module docstring).

    Args:
        settings: the runner's settings (limits included).
        lockstep: ticked in lock-step on sim time (no staleness, a stop request at the end)
            rather than on a wall clock.
        end_run: the end of the protocol ends the run (default ``stop_on_end``; a node that
            serves protocol goals stays up).
        labels: how messages name each input (default: its name), e.g. its topic.
    """

    def __init__(self, settings: RunnerSettings, lockstep: bool = True,
                 end_run: bool | None = None, labels: dict[str, str] | None = None) -> None:
        self.settings = settings
        self.lockstep = lockstep
        self.end_run = settings.stop_on_end if end_run is None else end_run
        self.labels = {n: (labels or {}).get(n, n) for n in INPUTS}
        self.limits = settings.limits()
        self.pause_vent = settings.pause_action == 'vent'
        self.suspenders = suspenders_of(settings.suspenders_yaml)
        self.core: Sequencer | None = None
        self.meas = Measurement(0.0, 0.0, 0.0)
        self.drive_torque_nm = 0.0                       # the loading servo's, on a wall clock
        self.samples: list[tuple[float, float]] = []     # load-cell (stamp s, N) since a tick
        self.x_samples: list[tuple[float, float]] = []   # encoder (stamp s, m) since a tick
        self.bands = {r.input: (r.low, r.high) for r in self.suspenders.rules
                      if r.input in ('force', 'contraction')}
        self.stamps: dict[str, float] = {}               # input -> stamp of its latest value
        self.start_pending = False
        self.step_request = EventStepRequest(settings.command_step_s)
        self._last_status_t = -math.inf
        self._last_phase: Phase | None = None
        self._end_s: float | None = None
        self._notes: list[Note] = []

    # --- the protocol -------------------------------------------------------------------
    def load(self, core: Sequencer) -> None:
        """Run ``core`` next: it starts at the next tick once the inputs are there
        (``start`` starts it at once)."""
        self.core = core
        core.bands = dict(self.bands)
        self.start_pending = True
        self._end_s = None
        self._last_phase = None

    def start(self, t_s: float) -> None:
        """Start the loaded protocol now (lock-step: at t_0)."""
        if self.core is not None:
            self.core.start(t_s)
            self.start_pending = False

    @property
    def ended(self) -> bool:
        """The protocol has ended (done, aborted or cancelled)."""
        return self.core is not None and not self.core.running and \
            self.core.phase != Phase.IDLE

    @property
    def busy(self) -> bool:
        """A protocol is running or about to start (a new one is refused)."""
        return self.core is not None and (self.core.running or self.start_pending)

    def retune(self, settings: RunnerSettings) -> None:
        """Take new tunable settings (status period, stale timeout, suspenders) between two
        ticks; new suspenders start unheld."""
        if settings.suspenders_yaml != self.settings.suspenders_yaml:
            self.suspenders = suspenders_of(settings.suspenders_yaml)
            self.bands = {r.input: (r.low, r.high) for r in self.suspenders.rules
                          if r.input in ('force', 'contraction')}
            if self.core is not None:
                self.core.bands = dict(self.bands)
        self.settings = settings

    # --- inputs -------------------------------------------------------------------------
    def measured(self, name: str, value: float, stamp_s: float) -> str:
        """The latest ``name`` ('force' N, 'contraction' m, 'pressure' gauge Pa, 'drive' the
        loading servo's torque N m) at ``stamp_s``. A value that is not finite is rejected: it
        aborts a running protocol (vented at the next tick). Returns the rejection ('' when
        accepted)."""
        if not math.isfinite(value):
            if self.core is not None and self.core.running:
                self.core.stop(Phase.ABORTED, f'measured {self.labels[name]} not finite')
            return f'measurement on {self.labels[name]} (protocol aborted, valve vented)'
        self.stamps[name] = stamp_s
        m = self.meas
        if name == 'force':
            self.meas = Measurement(value, m.contraction_m, m.pressure_pa)
            self.samples.append((stamp_s, value))
        elif name == 'contraction':
            self.meas = Measurement(m.force_n, value, m.pressure_pa)
            self.x_samples.append((stamp_s, value))
        elif name == 'drive':
            self.drive_torque_nm = value
        else:
            self.meas = Measurement(m.force_n, m.contraction_m, value)
        return ''

    def samples_in(self, samples: list[tuple[float, float]]) -> None:
        """Load-cell samples (stamp s, N) of a record that came in a batch, before the latest
        force (``measured``)."""
        self.samples += samples

    # --- operator -----------------------------------------------------------------------
    def pause(self, reason: str = 'paused by the operator', vent: bool | None = None
              ) -> tuple[bool, str]:
        """Pause at the next safe point, held or vented (default: ``pause_action``).
        Returns (accepted, message)."""
        core = self.core
        ok = core is not None and core.running and core.phase != Phase.PAUSED
        if ok and core is not None:
            core.pause(reason, vent=self.pause_vent if vent is None else vent)
            self._notes.append(Note(WARN, 'protocol pause requested'))
        return ok, 'pausing at the next safe point' if ok else 'nothing to pause'

    def resume(self) -> tuple[bool, str]:
        """End a pause. Returns (accepted, message); refused while a suspender holds."""
        core = self.core
        ok = core is not None and core.running and not self.suspenders.suspended
        if ok and core is not None:
            core.resume()
            self._notes.append(Note(OK, 'protocol resume requested'))
        return ok, ('resuming' if ok else 'a suspender holds the run'
                    if self.suspenders.suspended else 'nothing to resume')

    def cancel(self, reason: str = 'cancelled by the client') -> None:
        """Cancel the protocol, running or still waiting to start (vented at the next
        tick)."""
        self._end_early(Phase.CANCELLED, reason)

    def abort_start(self, reason: str) -> None:
        """Give up a protocol that waits to start (its inputs did not come): it ends
        ABORTED with ``reason``, and the node serving goals stays up for the next one."""
        if self.start_pending:
            self._end_early(Phase.ABORTED, reason)

    def _end_early(self, phase: Phase, reason: str) -> None:
        core = self.core
        if core is None:
            return
        if self.start_pending:                   # not started: it ends before its settle
            self.start_pending = False
            core.stop(phase, reason)
        elif core.running:
            core.stop(phase, reason)

    def fault(self, reason: str) -> None:
        """The node failed a step: abort (vented at the next tick)."""
        if self.core is not None:
            self.core.stop(Phase.ABORTED, reason)

    def take_notes(self) -> list[Note]:
        """The notes taken since the last tick (an operator's request between ticks)."""
        notes, self._notes = self._notes, []
        return notes

    # --- ticking ------------------------------------------------------------------------
    def waiting_for(self, gate: str = '') -> list[str]:
        """What a wall-clock start still waits for: the node's ``gate`` and the inputs that
        have not come."""
        return ([gate] if gate else []) + [n for n in INPUTS if n not in self.stamps]

    def tick(self, t_s: float, gate: str = '') -> Tick:
        """One tick at ``t_s``; ``gate``: what else a wall-clock start waits for ('' none)."""
        notes = self.take_notes()
        core = self.core
        if self.start_pending and core is not None and not self.lockstep:
            waiting = self.waiting_for(gate)
            if waiting:
                self.samples, self.x_samples = [], []
                return Tick(VENTED, notes=notes, waiting=waiting)
        if self.start_pending and core is not None:
            self.start(t_s)
        if core is None:
            self.samples, self.x_samples = [], []
            return Tick(VENTED, notes=notes)
        exit_code = None
        if self._end_s is not None and t_s >= self._end_s:
            exit_code = END_CODES.get(core.phase, 4)
        if core.running and not self.lockstep:
            self._stale_check(t_s, notes)
        samples, self.samples = self.samples, []
        x_samples, self.x_samples = self.x_samples, []
        self._suspend_check(t_s, notes)
        cmd = core.tick(t_s, self.meas, samples, x_samples)
        if cmd.point is not None:
            self.suspenders.reading_taken()
            if cmd.point.outliers:
                self._outliers(cmd.point, notes)
        due = core.phase != self._last_phase or t_s - self._last_status_t >= \
            self.settings.status_period_s
        if due:
            self._last_status_t, self._last_phase = t_s, core.phase
        step = self.step_request.request(t_s, core.next_event_s(t_s), (core.index, core.phase))
        out = Tick(cmd, due, notes, None, exit_code, step)
        if self.ended and self.end_run:
            if not self.lockstep:
                if self._end_s is None:
                    self._end_s = t_s + self.settings.end_linger_s
            else:
                out.stop = StopRequest(END_CODES[core.phase], f'protocol {core.name} '
                                       f'{core.phase.value}'
                                       + (f': {core.reason}' if core.reason else ''))
        return out

    def _stale_check(self, t_s: float, notes: list[Note]) -> None:
        """Abort on an input older than ``stale_timeout_s`` (one a suspender watches the
        staleness of holds the run suspended instead)."""
        assert self.core is not None
        watched = self.suspenders.watched_stale() if self.suspenders.suspended else set()
        for name in INPUTS:
            if name in watched:
                continue
            age = t_s - self.stamps.get(name, -math.inf)
            if age > self.settings.stale_timeout_s:
                self.core.stop(Phase.ABORTED, f'measured {self.labels[name]} stale '
                               f'({age:.3f} s old)')
                notes.append(Note(ERROR, self.core.reason))
                return

    def _outliers(self, point: Point, notes: list[Note]) -> None:
        """Write up the samples a reading's window left out (outside the suspenders' band);
        with ``reading_outliers: suspend`` the run is suspended until the suspenders hold."""
        r = point.reading
        units = {'force': 'N', 'contraction': 'm'}
        shown = ', '.join(f'{name} {v:.4g} {units[name]} at {t:.3f} s'
                          for name, t, v in point.outliers[:3])
        more = len(point.outliers) - 3
        text = (f'reading {r.protocol} series {r.series} step {r.step}: '
                f'{len(point.outliers)} sample(s) of its {r.window_s * 1e3:.0f} ms window '
                f'outside the band, left out of the mean ({shown}'
                + (f', and {more} more' if more > 0 else '') + ')')
        notes.append(Note(WARN, text))
        core = self.core
        if self.settings.reading_outliers == 'suspend' and core is not None and core.running:
            core.pause(f'suspended: {text}', vent=self.pause_vent)
            self.suspenders.hold()
            notes.append(Note(WARN, f'protocol suspended: {text}'))

    def _suspend_check(self, t_s: float, notes: list[Note]) -> None:
        """Let the suspenders pause or resume a running protocol."""
        core = self.core
        if core is None or not core.running or not self.suspenders.rules:
            return
        m = self.meas
        values = {'force': m.force_n, 'contraction': m.contraction_m, 'pressure': m.pressure_pa,
                  'drive': self.drive_torque_nm}
        ages = (dict.fromkeys(values, 0.0) if self.lockstep else
                {n: t_s - self.stamps.get(n, -math.inf) for n in values})
        action, why = self.suspenders.update(t_s, values, ages)
        if action == 'suspend':
            core.pause(f'suspended: {why}', vent=self.pause_vent)
            notes.append(Note(WARN, f'protocol suspended: {why}'))
        elif action == 'resume':
            core.resume()
            notes.append(Note(OK, 'suspender satisfied: protocol resumed'))
        elif action == 'abort':
            core.stop(Phase.ABORTED, why)
            notes.append(Note(ERROR, f'protocol aborted: {why}'))
