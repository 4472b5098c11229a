"""The lock-step rules, tested directly with tables of stamps (no DDS)."""

from __future__ import annotations

import copy
import math
import random

import pytest

from pam_bench.sim.lockstep import (
    FLUSH_NS,
    MIN_STEP_NS,
    EventStepRequest,
    InputSpec,
    RunSummary,
    StepPlan,
    StopRequest,
    collect_inputs,
    first_missing,
    flush_tick,
    input_window,
    negotiate,
    prune,
    request_ns,
    take_inputs,
)

LAG = InputSpec()
SAME = InputSpec(same_step=True)
SAME_SAMPLES = InputSpec(same_step=True, samples=True)
LAG_SAMPLES = InputSpec(samples=True)
FROM_START = InputSpec(from_start=True)


@pytest.mark.parametrize('spec, prev_prev, prev, t, index, window', [
    (LAG, None, 0, 10, 0, None),                  # step 1 runs on the initial values
    (LAG, 0, 10, 20, 1, (0, 10)),                 # then the producer's previous step
    (FROM_START, None, 0, 10, 0, (-1, 0)),        # published at t_0 too: needed at step 1
    (SAME, None, 0, 10, 0, (0, 10)),              # same-step: the message stamped t itself
    (SAME, 10, 20, 30, 2, (20, 30)),
    (SAME_SAMPLES, 10, 20, 30, 2, (20, 30)),
    (LAG_SAMPLES, 10, 20, 30, 2, (10, 20)),
])
def test_input_window(spec: InputSpec, prev_prev: int | None, prev: int, t: int, index: int,
                      window: tuple[int, int] | None) -> None:
    assert input_window(spec, prev_prev, prev, t, index) == window


def test_a_step_waits_for_the_message_at_the_top_of_its_window() -> None:
    specs = {'a': SAME, 'b': LAG}
    buffers: dict[str, dict[int, str]] = {'a': {}, 'b': {10: 'b10'}}
    assert take_inputs(buffers, specs, 0, 10, 20, 1) is None        # a@20 missing
    buffers['a'][20] = 'a20'
    assert take_inputs(buffers, specs, 0, 10, 20, 1) == {'a': 'a20', 'b': 'b10'}


def test_samples_are_every_message_of_the_window_in_stamp_order() -> None:
    specs = {'s': SAME_SAMPLES}
    buffers = {'s': {20: 'c', 12: 'a', 16: 'b', 10: 'old', 25: 'next'}}
    assert take_inputs(buffers, specs, 0, 10, 20, 1) == {'s': ['a', 'b', 'c']}
    buffers = {'s': {12: 'a', 16: 'b'}}                # the grid point is not there yet
    assert take_inputs(buffers, specs, 0, 10, 20, 1) is None


def test_stamped_samples_come_with_their_stamps() -> None:
    specs = {'s': InputSpec(samples=True, stamped=True), 'x': SAME}
    buffers = {'s': {2: 'a', 5: 'b', 10: 'c', 12: 'later'}, 'x': {20: 'x20'}}
    assert take_inputs(buffers, specs, 0, 10, 20, 1) == {'s': [(2, 'a'), (5, 'b'), (10, 'c')],
                                                         'x': 'x20'}


def test_first_missing_names_the_buffer_and_stamp_a_step_waits_for() -> None:
    specs = {'a': LAG, 'b': SAME, 'c': LAG_SAMPLES}
    buffers: dict[str, dict[int, str]] = {'a': {10: 'a10'}, 'b': {}, 'c': {5: 'c5'}}
    missing = first_missing(buffers, specs, 0, 10, 20, 1)
    assert missing is not None and missing[0] is buffers['b'] and missing[1] == 20
    buffers['b'][20] = 'b20'
    missing = first_missing(buffers, specs, 0, 10, 20, 1)
    assert missing is not None and missing[0] is buffers['c'] and missing[1] == 10
    buffers['c'][10] = 'c10'
    assert first_missing(buffers, specs, 0, 10, 20, 1) is None
    assert take_inputs(buffers, specs, 0, 10, 20, 1) == {'a': 'a10', 'b': 'b20',
                                                         'c': ['c5', 'c10']}


def test_a_fast_producer_does_not_replace_what_a_slow_consumer_needs() -> None:
    specs = {'b': LAG}
    buffers = {'b': {10: 'b10', 20: 'b20', 30: 'b30'}}   # the producer is two steps ahead
    assert take_inputs(buffers, specs, 0, 10, 20, 1) == {'b': 'b10'}


@pytest.mark.parametrize('spec, kept', [
    (SAME, [25, 30]),          # same-step: what is stamped after t
    (LAG, [10, 20, 25, 30]),   # lagged: from prev on (the next step takes prev's successor)
])
def test_prune_keeps_what_a_later_step_may_need(spec: InputSpec, kept: list[int]) -> None:
    buffers = {'x': {k: k for k in (5, 10, 20, 25, 30)}}
    prune(buffers, {'x': spec}, 10, 20)
    assert sorted(buffers['x']) == kept


ALL_SPECS = [InputSpec(same, samples, from_start, stamped)
             for same in (False, True) for samples in (False, True)
             for from_start in (False, True) for stamped in (False, True)]


@pytest.mark.parametrize('seed', range(40))
def test_step_plan_gives_what_the_rules_give(seed: int) -> None:
    """StepPlan (the nodes' hot path) against first_missing, collect_inputs and prune, on
    random buffers of every kind of input, for first and later steps, complete or not."""
    rnd = random.Random(seed)
    specs = {f'in{i}': rnd.choice(ALL_SPECS) for i in range(rnd.randint(1, 6))}
    index = rnd.choice([0, 1, 5])
    prev_prev = None if index == 0 else 10 * rnd.randint(1, 3)
    prev = (prev_prev or 0) + 10
    t = prev + rnd.choice([1, 10])
    buffers: dict[str, dict[int, str]] = {}
    for topic in specs:
        stamps = {rnd.randint(-1, t) for _ in range(rnd.randint(0, 8))}
        stamps |= {prev, t} if rnd.random() < 0.8 else set()
        buffers[topic] = {k: f'{topic}@{k}' for k in rnd.sample(sorted(stamps), len(stamps))}
    ref = copy.deepcopy(buffers)
    plan = StepPlan(buffers, specs)
    missing = plan.missing(prev, t, index)
    want = first_missing(ref, specs, prev_prev, prev, t, index)
    assert (missing is None) == (want is None)
    if want is not None:
        assert missing is not None and missing[1] == want[1] and missing[0] == want[0]
        return
    got = plan.take(prev_prev, prev, t, index)
    assert got == collect_inputs(ref, specs, prev_prev, prev, t, index)
    prune(ref, specs, prev, t)
    assert buffers == ref
    assert all(sorted(b) == sorted(ref[k]) for k, b in buffers.items())


def test_step_plan_sees_what_arrives_after_it_was_made() -> None:
    buffers: dict[str, dict[int, str]] = {'a': {}, 'b': {10: 'b10'}}
    plan = StepPlan(buffers, {'a': SAME, 'b': LAG})
    assert plan.missing(10, 20, 1) == ({}, 20)
    buffers['a'][20] = 'a20'
    assert plan.missing(10, 20, 1) is None
    assert plan.take(0, 10, 20, 1) == {'a': 'a20', 'b': 'b10'}
    assert buffers == {'a': {}, 'b': {10: 'b10'}}          # lagged: from prev on


@pytest.mark.parametrize('longest, requests, remaining, step', [
    (3_000_000_000, [], None, 3_000_000_000),
    (3_000_000_000, [0, 1_000_000], None, 1_000_000),            # 0 asks for nothing
    (3_000_000_000, [2_000_000, 1_000_000], None, 1_000_000),    # the shortest request wins
    (3_000_000_000, [5_000_000_000], None, 3_000_000_000),       # never longer than longest
    (3_000_000_000, [1_000_000], 500_000, 500_000),              # nor past the run's end
    (0.5, [0.0, 0.1, 0.25], None, 0.1),                          # seconds in the twin
])
def test_negotiate(longest: float, requests: list[float], remaining: float | None,
                   step: float) -> None:
    assert negotiate(longest, requests, remaining) == step


@pytest.mark.parametrize('seconds, ns', [(0.001, 1_000_000), (3.0, 3_000_000_000),
                                         (1e-9, MIN_STEP_NS), (2.5e-7, MIN_STEP_NS)])
def test_request_ns(seconds: float, ns: int) -> None:
    assert request_ns(seconds) == ns


def test_event_request_lands_on_events_and_asks_a_command_step_at_new_set_values() -> None:
    req = EventStepRequest(command_step_s=0.001)
    assert req.request(0.0, 3.0, (0, 'dwell')) == 0.001          # a new reading
    assert req.request(0.001, 3.0, (0, 'dwell')) == pytest.approx(2.999)
    assert req.request(2.999999999, 3.0, (0, 'dwell')) == 1e-6    # never below 1 us
    assert req.request(3.0, math.inf, (1, 'dwell')) == 0.001
    assert req.request(3.001, math.inf, (1, 'dwell')) == 0.0       # nothing to land on


def test_flush_tick_and_stop_request() -> None:
    assert flush_tick(7_000_000_000) == 7_000_000_000 + FLUSH_NS
    stop = StopRequest(4, 'protocol isometric aborted')
    assert (stop.exit_code, stop.reason) == (4, 'protocol isometric aborted')


def test_run_summary_round_trips_as_json() -> None:
    s = RunSummary(0, 120, 6.0, 2.0, 'protocol demo done')
    back = RunSummary.from_json(s.to_json())
    assert back == s and back.rate == 60.0 and back.real_time_factor == 3.0
    assert 'protocol demo done' in s.line()
    with pytest.raises((ValueError, KeyError)):
        RunSummary.from_json('{"steps": 3}')
