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
