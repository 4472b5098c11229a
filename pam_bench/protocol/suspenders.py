"""Suspenders: conditions on the measured inputs that pause a run by themselves and resume it
when the inputs are good again (the pattern of bluesky's suspenders, for a pneumatic bench).

A rule watches one measured quantity: ``force`` (N), ``contraction`` (m), ``pressure``
(gauge Pa) or ``drive`` (the loading servo's torque on ``loading_servo/state``, N m: on a wall
clock its age says whether the drive follows; a CANopen drive in fault or quick stop publishes
no state). It trips when the value leaves [low, high] or (on a wall clock) when the input is
older than ``stale_s``; the run resumes once every rule has been satisfied for
``resume_after_s`` without a break. No suspension lasts for ever: once the smallest
``max_hold_s`` of the rules has passed since the first trip after the last reading the run
took, the next trip (or the hold still going on) aborts the run with the reason it was
suspended for. A rule the run itself cannot satisfy (a pressure floor at a vented valve) or one
that trips again at every restart of a reading would otherwise hold it until someone notices.
Rules come from YAML (the sequencer's ``suspenders_yaml``), strictly: an unknown key is an
error naming it.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

from pam_bench.vocabulary.errors import ParameterError, shorten
from pam_bench.vocabulary.params import check_known

__all__ = ['Rule', 'Suspenders', 'parse_rules', 'INPUTS']

INPUTS = ('force', 'contraction', 'pressure', 'drive')
MAX_HOLD_S = 86400.0
"""The longest ``max_hold_s`` a rule may have: a day."""


@dataclasses.dataclass(frozen=True)
class Rule:
    """One suspender: input, band [low, high] (unit of the input), stale bound (s, inf: none),
    how long the input must be good again before the run resumes (s) and the longest it may
    hold the run suspended before the run aborts (s, finite)."""

    input: str
    low: float = -math.inf
    high: float = math.inf
    stale_s: float = math.inf
    resume_after_s: float = 1.0
    max_hold_s: float = 60.0

    def problem(self, value: float, age_s: float) -> str:
        """Why the rule trips now ('' when it does not)."""
        if age_s > self.stale_s:
            return f'{self.input} stale ({age_s:.3f} s old)'
        if not math.isfinite(value):
            return f'{self.input} not finite'
        if not self.low <= value <= self.high:
            return f'{self.input} {value:.4g} outside [{self.low:.4g}, {self.high:.4g}]'
        return ''


def parse_rules(data: Any) -> list[Rule]:
    """Rules from a parsed YAML list of mappings.

    Raises:
        ParameterError: not a list of mappings, an unknown key or input, a bad number.
    """
    if data in (None, ''):
        return []
    if not isinstance(data, list):
        raise ParameterError(f'suspenders: a list of rules, got {shorten(data)}')
    rules = []
    keys = [f.name for f in dataclasses.fields(Rule)]
    for i, item in enumerate(data):
        if not isinstance(item, Mapping):
            raise ParameterError(f'suspenders[{i}]: a mapping, got {item!r}')
        check_known(item, keys, f'suspenders[{i}]')
        if item.get('input') not in INPUTS:
            raise ParameterError(f'suspenders[{i}].input: one of {", ".join(INPUTS)}, got '
                                 f'{item.get("input")!r}')
        try:
            values = {k: float(v) for k, v in item.items() if k != 'input'}
        except (TypeError, ValueError):
            raise ParameterError(f'suspenders[{i}]: numbers expected, got '
                                 f'{shorten(item)}') from None
        hold = values.get('max_hold_s', Rule.max_hold_s)
        if not 0.0 < hold <= MAX_HOLD_S:
            raise ParameterError(f'suspenders[{i}].max_hold_s: {hold:g} s is not in (0, '
                                 f'{MAX_HOLD_S:g}] s (a suspension must end)')
        rules.append(Rule(item['input'], **values))
    return rules


class Suspenders:
    """The rules of a run and whether they hold the run suspended."""

    def __init__(self, rules: list[Rule]) -> None:
        self.rules = rules
        self.suspended = False
        self._good_since: float | None = None
        self._since: float | None = None   # the first trip since the last reading (clock, s)
        self.max_hold_s = min((r.max_hold_s for r in rules), default=Rule.max_hold_s)

    def watched_stale(self) -> set[str]:
        """Inputs whose staleness a rule watches (a run it suspends waits instead of
        aborting for them)."""
        return {r.input for r in self.rules if math.isfinite(r.stale_s)}

    def hold(self) -> None:
        """Hold the run suspended from now until every rule has held for its
        ``resume_after_s`` (a reading whose window had samples outside the band)."""
        self.suspended = True
        self._good_since = None

    def reading_taken(self) -> None:
        """The run took a reading: the longest hold counts afresh from the next trip."""
        if not self.suspended:
            self._since = None

    def update(self, t_s: float, values: Mapping[str, float], ages_s: Mapping[str, float]
               ) -> tuple[str, str]:
        """Check every rule at ``t_s``; returns (action, reason): ('suspend', why) when a rule
        trips while not suspended, ('resume', '') when all have held for their
        ``resume_after_s``, ('abort', why) once suspended longer than ``max_hold_s``, else
        ('', why or '')."""
        problems = [p for r in self.rules
                    if (p := r.problem(values.get(r.input, math.nan),
                                       ages_s.get(r.input, math.inf)))]
        if self.suspended or problems:
            if self._since is None:
                self._since = t_s
            if t_s - self._since > self.max_hold_s:
                self.suspended = False
                self._since = self._good_since = None
                why = problems[0] if problems else 'the inputs were not good long enough'
                return 'abort', (f'held by its suspenders for more than {self.max_hold_s:g} s '
                                 f'since the last reading (max_hold_s): {why}')
        if problems:
            self._good_since = None
            if not self.suspended:
                self.suspended = True
                return 'suspend', problems[0]
            return '', problems[0]
        if not self.suspended:
            return '', ''
        if self._good_since is None:
            self._good_since = t_s
        if t_s - self._good_since >= max(r.resume_after_s for r in self.rules):
            self.suspended = False
            self._good_since = None
            return 'resume', ''
        return '', ''
