"""BENCHMARKS.md is rendered from the data: key results first, one section per bench.json key
of every study with its method, the hand-written long runs included whole. The figures come
from a report made up here, so a re-measured bench.json changes nothing."""

from __future__ import annotations

import json
import pathlib

import pytest

from benchmarks.report import key_results, render
from benchmarks.studies import STUDIES, study
from benchmarks.tables import LONG_RUNS, methods, table

REPO = pathlib.Path(__file__).resolve().parents[2]


def test_table_helper() -> None:
    assert table(['a', 'b'], [(1, 'x'), (2.5, '')]) == ['| a | b |', '|---|---|', '| 1 | x |',
                                                        '| 2.5 |  |']


def test_one_list_of_studies_each_section_with_a_title_and_a_short_method() -> None:
    keys = [s.key for s in STUDIES]
    assert len(keys) == len(set(keys))
    fills = [k for s in STUDIES for k in s.fills]
    assert len(fills) == len(set(fills))
    assert set(fills) == set(methods()), 'methods.yaml has a section for every key, no other'
    for key in fills:
        text = methods()[key]
        assert text['title'] and text['method']
        assert text['method'].count('. ') <= 3, key


def _made_up() -> dict:
    """A report holding two studies' figures, with numbers no run measured."""
    figs = [{'text': 'isometric gain at 0 mm', 'paper': 284.3, 'bench': 280.0, 'unit': 'N/V',
             'difference': -0.015, 'relative': True, 'tolerance': 0.1, 'at_least': False,
             'ok': True}]
    return {'machine': {'platform': 'test', 'cpus': 2, 'python': '3.11'}, 'date': 'today',
            'commit': 'abc1234', 'quick': True,
            'measured': {'lockstep': {'commit': 'def5678'}},
            'calibration': {'figures_004': figs, 'isometric_gain_N_per_V_at_0mm': 281.5,
                            'isometric_gain_N_per_V_at_95mm': 17.0,
                            'contraction_mm_at_6V_50N': 101.0, 'force_N_at_6V_0mm': 1234.0,
                            'isobaric_hysteresis_mm_max': 1.5},
            'lockstep': {'pingpong_round_trips_per_s': 2000.0,
                         'demo_lockstep_steps_per_s': 400.0,
                         'ratio_lockstep_to_pingpong': 0.2, 'participants': 7}}


def test_key_results_come_from_the_data_with_each_commit() -> None:
    rows = key_results(_made_up())
    assert all(len(row) == 4 for row in rows)
    assert rows[0] == ("004's figures on its full grids within issue 18's tolerances",
                       '1 of 1', '1 of 1', '`abc1234`')
    assert ('force at 6 V, x = 0', '>= 900 N (004)', '1234 N', '`abc1234`') in rows
    assert rows[-1][2].startswith('5.0 round trips') and rows[-1][3] == '`def5678`'


def test_render_opens_with_key_results_has_what_the_data_holds_and_long_runs(
        tmp_path: pathlib.Path) -> None:
    (tmp_path / 'docs').mkdir()
    (tmp_path / LONG_RUNS).write_text('## Long runs\n\nhand-written text\n\n'
                                      '### A dated note (2026-12-05)\n\nmore text\n')
    md = render(_made_up(), tmp_path)
    heads = [line for line in md.splitlines() if line.startswith('## ')]
    assert heads[:3] == ['## Key results', f"## {methods()['calibration']['title']}",
                         f"## {methods()['lockstep']['title']}"]
    assert heads[-1] == '## Long runs and dated notes' and 'hand-written text' not in md
    assert md.rstrip().endswith('- Long runs\n- A dated note (2026-12-05)')
    assert len(heads) == 4                       # no section for what the data lacks
    assert '| isometric gain at x = 0 mm | 281.5 N/V |' in md


def test_the_committed_report_renders(tmp_path: pathlib.Path) -> None:
    """Whatever bench.json holds now renders (its figures are not asserted)."""
    r = json.loads((REPO / 'results' / 'bench.json').read_text(encoding='utf-8'))
    assert render(r, tmp_path).startswith('# pam_bench benchmarks')


def test_an_unknown_study_names_the_nearest() -> None:
    from benchmarks.errors import UsageError
    from benchmarks.suite import run_benchmarks
    with pytest.raises(UsageError, match="did you mean 'layouts'"):
        run_benchmarks(True, REPO, only=['layuots'])
    assert study('layouts').key == 'layouts'


def test_best_case_of_separate_processes_adds_the_no_work_floor_and_the_work() -> None:
    """Without a delivery count, 1 / (1 / no-work rate + 1 / composed rate / cores): 7
    participants at 1000/s and a composed demo at 2000/s on 2 cores give 1 / (1 ms + 0.25 ms)
    = 800/s; with one, each delivery costs what one of the no-work lock-step does."""
    from benchmarks.layouts import _best_case

    def row(layout: str, rate: float) -> dict[str, object]:
        return {'scene': 'demo', 'layout': layout, 'sim_s': 10.0, 'exchange_steps': 1000,
                'lockstep_rate_steps_per_s': rate}

    r = {'machine': {'cpus': 2}, 'layouts': {
        'pingpong_round_trips_per_s': 2000.0, 'fanout_exchanges_per_s': {'7': 1000.0},
        'rows': [row('one process', 2000.0), row('separate processes', 300.0)]}}
    text = ' '.join(_best_case(r))
    assert 'demo 800 exchanges/s (8.00x real time, 0.40 of the ping-pong, measured 300/s)' \
        in text
    assert 'servo_sin_t' not in text                        # no row of it: left out
    # with the deliveries counted: 7 participants at 1000/s on 2 cores are 14 deliveries in
    # 2 ms of CPU, 143 us each; 21 deliveries are 3 ms, 1.5 ms on 2 cores, plus 0.25 ms work
    r['layouts']['rows'][0]['deliveries_per_exchange'] = 21.0
    text = ' '.join(_best_case(r))
    assert 'demo 21.0 deliveries at 143 us, 571 exchanges/s (5.71x real time, 0.29 of' in text
    r['layouts']['fanout_exchanges_per_s'] = {}
    assert _best_case(r) == []
