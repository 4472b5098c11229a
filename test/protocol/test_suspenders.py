"""Suspenders: rules parsed strictly, a trip suspends once, a resume waits for good data."""

from __future__ import annotations

import math

import pytest

from pam_bench.protocol.suspenders import Rule, Suspenders, parse_rules
from pam_bench.vocabulary.errors import ParameterError


@pytest.mark.parametrize('value, age, words', [
    (5e4, 0.0, ''),
    (1e4, 0.0, 'outside'),
    (5e4, 2.0, 'stale'),
    (math.nan, 0.0, 'not finite'),
])
def test_a_rule_says_why_it_trips(value: float, age: float, words: str) -> None:
    rule = Rule('pressure', low=2e4, high=9e5, stale_s=1.0)
    got = rule.problem(value, age)
    assert (words in got) if words else got == ''


def test_suspend_once_then_resume_after_good_data_for_long_enough() -> None:
    s = Suspenders([Rule('force', low=-20.0, high=1500.0, resume_after_s=0.5)])
    assert s.update(0.0, {'force': 0.0}, {'force': 0.0}) == ('', '')
    action, why = s.update(1.0, {'force': -50.0}, {'force': 0.0})
    assert action == 'suspend' and 'force -50' in why
    assert s.update(1.1, {'force': -60.0}, {'force': 0.0})[0] == ''    # once, not again
    assert s.update(1.2, {'force': 0.0}, {'force': 0.0}) == ('', '')   # good since 1.2
    assert s.update(1.5, {'force': -30.0}, {'force': 0.0})[0] == ''    # a break: again
    assert s.update(1.6, {'force': 0.0}, {'force': 0.0}) == ('', '')
    assert s.update(2.0, {'force': 0.0}, {'force': 0.0}) == ('', '')
    assert s.update(2.1, {'force': 0.0}, {'force': 0.0}) == ('resume', '')
    assert not s.suspended


@pytest.mark.parametrize('data, words', [
    ([{'input': 'force', 'lowe': 1.0}], "'lowe'"),
    ([{'input': 'flow'}], 'input'),
    ({'input': 'force'}, 'list'),
    ([{'input': 'force', 'low': 'x'}], 'numbers'),
])
def test_bad_rules_are_one_clear_error(data: object, words: str) -> None:
    with pytest.raises(ParameterError, match=words):
        parse_rules(data)


def test_rules_parse() -> None:
    rules = parse_rules([{'input': 'pressure', 'low': 2e4, 'resume_after_s': 2}])
    assert rules == [Rule('pressure', low=2e4, resume_after_s=2.0)]
