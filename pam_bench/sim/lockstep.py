"""The lock-step rules, once, without ROS: shared by the nodes, the sim clock and the twin.

Lock-step (README, "Time and determinism"): the sim clock publishes t_k; a participant steps
to t_k once it holds, for every synchronous input, the message the rule below names, then
publishes its outputs stamped t_k and acknowledges t_k, possibly asking for a shorter next step.

Input windows. A participant that last stepped to ``prev`` = t_(k-1) (and before that to
``prev_prev`` = t_(k-2)) takes, for the step to t = t_k:

* a *same-step* input: the message stamped t itself (an open chain valve -> muscle -> load
  cell within one exchange); with *samples*, every message stamped in (prev, t];
* a *lagged* input: the message stamped prev (the producer's previous step); with *samples*,
  every message stamped in (prev_prev, prev]; at the first step (``step_index`` 0) nothing,
  the step runs on initial values, unless the input is *from_start* (its producer publishes at
  t_0 too).

With *stamped* (and *samples*) the list holds (stamp ns, message) pairs, for a consumer that
needs the stamps (the recorder) and would otherwise read them again from every message.
With *blocks* (and *samples*) the consumer also takes, in process, a block of consecutive
samples carried as one object stamped with its last one (``runtime.messages.ForceSamples``); a
producer sends blocks only to consumers that all take them, and never on the grid.

The step waits until the message stamped at the window's upper end is there; sub-step samples
are stamped at their own times, the last on the grid. After the step, messages no later input
window can need are dropped.

Step negotiation. The next exchange step is the scene's longest step, cut by every positive
request (a participant's ``max_next_step``, at least ``MIN_STEP_NS``) and by what remains to
``duration_s``: ``negotiate``. The sequencer asks to land on its next event and for its
``command_step_s`` at each new reading or phase: ``EventStepRequest``.

End. A participant (the sequencer, at the end of its protocol) asks the clock to stop with a
``StopRequest`` in its acknowledgement; the clock then publishes the flush tick t_N + 1 ns
(``flush_tick``) so that every participant, the recorder above all, takes in what is stamped
t_N, and ends once all have acknowledged it, writing a ``RunSummary``.
"""

from __future__ import annotations

import dataclasses
import enum
import json
import math
from collections.abc import Iterable, Mapping
from typing import Any, NamedTuple, TypeVar

__all__ = ['InputSpec', 'input_window', 'take_inputs', 'collect_inputs', 'first_missing',
           'prune', 'StepPlan', 'FLUSH_NS', 'flush_tick', 'MIN_STEP_NS', 'request_ns', 'negotiate',
           'EventStepRequest', 'StopRequest', 'ClockState', 'RunSummary', 'Ack']

M = TypeVar('M')
N = TypeVar('N', int, float)

FLUSH_NS = 1
"""ns: the flush tick follows the last step by this much."""
MIN_STEP_NS = 1000
"""ns: the shortest exchange step a participant can ask for (1 us)."""


@dataclasses.dataclass(frozen=True)
class InputSpec:
    """How a participant takes one synchronous input (module docstring)."""

    same_step: bool = False
    samples: bool = False
    from_start: bool = False
    stamped: bool = False
    blocks: bool = False


def input_window(spec: InputSpec, prev_prev_ns: int | None, prev_ns: int, t_ns: int,
                 step_index: int) -> tuple[int, int] | None:
    """The stamps (lo, hi] the step from ``prev_ns`` to ``t_ns`` takes of an input.

    Args:
        spec: the input's options.
        prev_prev_ns: the step before the previous one (None before the second step), ns.
        prev_ns: the previous step, ns.
        t_ns: the step being taken, ns.
        step_index: how many steps were taken before this one (0 at the first).

    Returns:
        (lo, hi): the input is every message stamped in (lo, hi] (``samples``) or the one
        stamped hi; None: this step does not take the input (initial values).
    """
    if spec.same_step:
        return prev_ns, t_ns
    if step_index >= 1 or spec.from_start:
        return (prev_prev_ns if prev_prev_ns is not None else -1), prev_ns
    return None


def take_inputs(buffers: Mapping[str, Mapping[int, M]], specs: Mapping[str, InputSpec],
                prev_prev_ns: int | None, prev_ns: int, t_ns: int, step_index: int
                ) -> dict[str, M | list[M] | list[tuple[int, M]]] | None:
    """The inputs of the step to ``t_ns``, or None while one is still missing.

    Args:
        buffers: topic -> {stamp ns: message} received so far.
        specs: topic -> options, for every topic of ``buffers``.
        prev_prev_ns: as ``input_window``.
        prev_ns: as ``input_window``.
        t_ns: as ``input_window``.
        step_index: as ``input_window``.

    Returns:
        topic -> the message (or, with ``samples``, the list of messages in stamp order; with
        ``stamped`` too, of (stamp, message) pairs) for every input this step takes; None
        when a message at a window's upper end is missing.
    """
    if first_missing(buffers, specs, prev_prev_ns, prev_ns, t_ns, step_index) is not None:
        return None
    return collect_inputs(buffers, specs, prev_prev_ns, prev_ns, t_ns, step_index)


def collect_inputs(buffers: Mapping[str, Mapping[int, M]], specs: Mapping[str, InputSpec],
                   prev_prev_ns: int | None, prev_ns: int, t_ns: int, step_index: int
                   ) -> dict[str, M | list[M] | list[tuple[int, M]]]:
    """``take_inputs`` once ``first_missing`` has said nothing is missing (arguments and
    result as there), for a caller that asked it already."""
    out: dict[str, M | list[M] | list[tuple[int, M]]] = {}
    for topic, buf in buffers.items():
        spec = specs[topic]
        window = input_window(spec, prev_prev_ns, prev_ns, t_ns, step_index)
        if window is None:
            continue
        lo, hi = window
        if not spec.samples:
            out[topic] = buf[hi]
        elif spec.stamped:
            out[topic] = [(k, buf[k]) for k in sorted(k for k in buf if lo < k <= hi)]
        else:
            out[topic] = [buf[k] for k in sorted(k for k in buf if lo < k <= hi)]
    return out


def first_missing(buffers: Mapping[str, Mapping[int, Any]], specs: Mapping[str, InputSpec],
                  prev_prev_ns: int | None, prev_ns: int, t_ns: int, step_index: int
                  ) -> tuple[Mapping[int, Any], int] | None:
    """The first input the step to ``t_ns`` still waits for, as (its buffer, the stamp the step
    needs), or None when the step can be taken (arguments as ``take_inputs``). Until that
    stamp is in that buffer the step cannot be taken, whatever else arrives: a participant
    need not look at its other inputs again before."""
    for topic, buf in buffers.items():
        window = input_window(specs[topic], prev_prev_ns, prev_ns, t_ns, step_index)
        if window is not None and window[1] not in buf:
            return buf, window[1]
    return None


def prune(buffers: Mapping[str, dict[int, Any]], specs: Mapping[str, InputSpec],
          prev_ns: int, t_ns: int) -> None:
    """Drop what the step from ``prev_ns`` to ``t_ns`` consumed and no later step needs: a
    same-step input needs messages after t from now on, a lagged one from prev on."""
    for topic, buf in buffers.items():
        same = specs[topic].same_step
        for k in [k for k in buf if (k <= t_ns if same else k < prev_ns)]:
            del buf[k]


class StepPlan:
    """One participant's input rules laid out once for its hot path: ``missing`` is
    ``first_missing`` and ``take`` is ``collect_inputs`` followed by ``prune``, in one pass
    over the inputs and without looking up a spec per input and per step (the same results,
    ``test_lockstep`` compares them on tables and on random buffers).

    Args:
        buffers: topic -> {stamp ns: message}, the participant's live buffers (kept, not
            copied: what arrives later is seen).
        specs: topic -> options, for every topic of ``buffers``.
    """

    def __init__(self, buffers: Mapping[str, dict[int, Any]],
                 specs: Mapping[str, InputSpec]) -> None:
        self._rows = [(topic, buf, specs[topic].same_step, specs[topic].samples,
                       specs[topic].from_start, specs[topic].stamped)
                      for topic, buf in buffers.items()]

    def missing(self, prev_ns: int, t_ns: int, step_index: int
                ) -> tuple[dict[int, Any], int] | None:
        """As ``first_missing`` (the window's lower end does not matter here)."""
        first = step_index == 0
        for _, buf, same, _, from_start, _ in self._rows:
            if same:
                if t_ns not in buf:
                    return buf, t_ns
            elif (from_start or not first) and prev_ns not in buf:
                return buf, prev_ns
        return None

    def take(self, prev_prev_ns: int | None, prev_ns: int, t_ns: int, step_index: int
             ) -> dict[str, Any]:
        """The inputs of the step to ``t_ns`` (as ``collect_inputs``, once ``missing`` said
        none is missing), then drops what no later step needs (as ``prune``)."""
        out: dict[str, Any] = {}
        first = step_index == 0
        low = prev_prev_ns if prev_prev_ns is not None else -1
        for topic, buf, same, samples, from_start, stamped in self._rows:
            if same:
                lo, hi, cut = prev_ns, t_ns, t_ns
            elif from_start or not first:
                lo, hi, cut = low, prev_ns, prev_ns - 1
            else:
                lo, hi, cut = -1, -1, prev_ns - 1           # initial values: take nothing
            if samples:
                pairs = []
                dead = []
                for kv in buf.items():
                    k = kv[0]
                    if lo < k <= hi:
                        pairs.append(kv)
                    if k <= cut:
                        dead.append(k)
                pairs.sort()                  # stamps are unique: messages never compared
                if hi >= 0:
                    out[topic] = pairs if stamped else [v for _, v in pairs]
            else:
                if hi >= 0:
                    out[topic] = buf[hi]
                dead = []                     # drop every stamp <= cut (loops, not list
                for k in buf:                 # comprehensions: buffers hold a few messages)
                    if k <= cut:
                        dead.append(k)
            if len(dead) == len(buf):
                buf.clear()
            else:
                for k in dead:
                    del buf[k]
        return out


def flush_tick(last_ns: int) -> int:
    """The flush tick after the last step ``last_ns`` (ns)."""
    return last_ns + FLUSH_NS


def request_ns(max_next_step_s: float) -> int:
    """A participant's request (s, > 0) as a step in ns, at least ``MIN_STEP_NS``."""
    return max(round(max_next_step_s * 1e9), MIN_STEP_NS)


def negotiate(longest: N, requests: Iterable[N], remaining: N | None = None) -> N:
    """The next exchange step: ``longest``, cut by every positive request and by what remains
    to the run's end (ns or s, the same unit for all)."""
    step = longest
    for req in requests:
        if req > 0 and req < step:
            step = req
    if remaining is not None and remaining < step:
        step = remaining
    return step


class EventStepRequest:
    """The sequencer's request for the next exchange step (module docstring).

    Args:
        command_step_s: step asked for at every new reading or phase (the loading servo takes
            a new set value one exchange after it is sent), s.
    """

    def __init__(self, command_step_s: float) -> None:
        self.command_step_s = command_step_s
        self._marker: object = None

    def request(self, t_s: float, next_event_s: float, marker: object) -> float:
        """The longest next step wanted after a tick at ``t_s`` (s; 0: any).

        Args:
            t_s: the tick, s.
            next_event_s: the next reading or record end (inf: none), s.
            marker: what identifies the reading and phase; a change is a new set value.
        """
        req = max(next_event_s - t_s, 1e-6) if math.isfinite(next_event_s) else 0.0
        if marker != self._marker:
            self._marker = marker
            req = min(req or math.inf, self.command_step_s)
        return req


@dataclasses.dataclass(frozen=True)
class StopRequest:
    """A participant's request to end the run: the exit code and why."""

    exit_code: int
    reason: str


class Ack(NamedTuple):
    """A participant's acknowledgement of the tick ``t_ns`` (the StepAck message's content;
    a named tuple: one is made per participant and exchange, and a tuple is made fastest).

    Attributes:
        t_ns: the tick acknowledged, ns.
        node: the participant's fully qualified name.
        max_next_step_s: the longest next step it wants, s (0: any).
        stop: its request to end the run, if any.
    """

    t_ns: int
    node: str
    max_next_step_s: float
    stop: StopRequest | None


class ClockState(enum.Enum):
    """Where the sim clock is in a run."""

    WAITING = 'waiting'       # repeating t_0 until every participant acknowledged it
    GRACE = 'grace'           # all ready; waiting grace_s of wall time for late matches
    RUNNING = 'running'       # advancing on acknowledgements
    FLUSHING = 'flushing'     # the flush tick is out; ends when all acknowledged it
    DONE = 'done'


@dataclasses.dataclass(frozen=True)
class RunSummary:
    """How a lock-step run ended: exit code, exchange steps, sim and wall time, reason."""

    exit_code: int
    steps: int
    sim_s: float
    wall_s: float
    reason: str

    @property
    def rate(self) -> float:
        """Exchange steps per wall second."""
        return self.steps / self.wall_s if self.wall_s > 0 else 0.0

    @property
    def real_time_factor(self) -> float:
        """Sim seconds per wall second."""
        return self.sim_s / self.wall_s if self.wall_s > 0 else 0.0

    def to_json(self) -> str:
        """One JSON object (the clock writes it to its ``summary_file``)."""
        return json.dumps(dataclasses.asdict(self))

    @classmethod
    def from_json(cls, text: str) -> RunSummary:
        """Read what ``to_json`` wrote.

        Raises:
            ValueError: not a summary.
        """
        data = json.loads(text)
        return cls(int(data['exit_code']), int(data['steps']), float(data['sim_s']),
                   float(data['wall_s']), str(data['reason']))

    def line(self) -> str:
        """One line for the terminal."""
        return (f'lock-step: {self.steps} exchange steps, {self.sim_s:.2f} s sim in '
                f'{self.wall_s:.2f} s wall ({self.rate:.0f} steps/s, x{self.real_time_factor:.1f}'
                f' real time): {self.reason}')
