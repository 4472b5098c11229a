"""BENCHMARKS.md is rendered from the data: key results first, one section per study with its
method, the hand-written long runs included whole."""

from __future__ import annotations

import json
import pathlib

from pam_bench.benchmarks.report import LONG_RUNS, SECTIONS, key_results, methods, render, table

REPO = pathlib.Path(__file__).resolve().parents[2]


def test_table_helper() -> None:
    assert table(['a', 'b'], [(1, 'x'), (2.5, '')]) == ['| a | b |', '|---|---|', '| 1 | x |',
                                                        '| 2.5 |  |']


def test_every_section_has_a_title_and_a_short_method_without_figures() -> None:
    for key, _ in SECTIONS:
        text = methods()[key]
        assert text['title'] and text['method']
        assert text['method'].count('. ') <= 3, key


def _report() -> dict:
    return json.loads((REPO / 'bench.json').read_text(encoding='utf-8'))


def test_key_results_name_goal_value_and_commit() -> None:
    r = _report()
    rows = key_results(r)
    assert rows[0][0] == "004's figures on its full grids within issue 18's tolerances"
    commits = {f"`{m['commit']}`" for m in r.get('measured', {}).values()} | {f"`{r['commit']}`"}
    assert all(len(row) == 4 and row[3] in commits for row in rows)
    assert any('campaign' in row[0] for row in rows)


def test_render_opens_with_key_results_and_includes_long_runs(tmp_path: pathlib.Path) -> None:
    (tmp_path / 'docs').mkdir()
    (tmp_path / LONG_RUNS).write_text('## Long runs\n\nhand-written text\n')
    md = render(_report(), tmp_path)
    heads = [line for line in md.splitlines() if line.startswith('## ')]
    assert heads[0] == '## Key results'
    assert heads[-1] == '## Long runs' and 'hand-written text' in md
    report = _report()
    for key, _ in SECTIONS:
        assert (f"## {methods()[key]['title']}" in heads) == bool(report.get(key)), key
    assert (tmp_path / 'bench_work_precision.png').exists()


def test_best_case_of_separate_processes_adds_the_no_work_floor_and_the_work() -> None:
    """Without a delivery count, 1 / (1 / no-work rate + 1 / composed rate / cores): 7
    participants at 1000/s and a composed demo at 2000/s on 2 cores give 1 / (1 ms + 0.25 ms)
    = 800/s; with one, each delivery costs what one of the no-work lock-step does."""
    from pam_bench.benchmarks.report import _best_case

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
