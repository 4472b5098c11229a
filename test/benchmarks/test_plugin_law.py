"""Study ``plugin_law``: its table and its key row from the runs' times."""

from __future__ import annotations

from benchmarks.plugin_law import results, section

TIMES = {'law': 'hunt_graber_quinn', 'runs': 3, 'scenes': {
    'demo': {'built_in': [1.3, 1.5, 1.4], 'law': [1.9, 1.6, 1.7]},
    'campaign_quick': {'built_in': [2.0, 2.2, 2.4], 'law': [3.3, 3.0, 3.2]}}}
REPORT = {'plugin_law': TIMES, 'measured': {'plugin_law': {'commit': 'abc1234'}}}


def test_the_ratio_is_of_the_medians() -> None:
    lines = section(REPORT)
    demo = next(ln for ln in lines if ln.startswith('| demo'))
    assert '1.30-1.50 s (median 1.40 s)' in demo and '(median 1.70 s)' in demo
    assert demo.rstrip(' |').endswith('1.21x'), demo           # 1.70 / 1.40
    (row,) = results(REPORT)
    assert row[1] == 'within 1.5x' and row[2] == 'demo 1.21x, campaign_quick 1.45x', row


def test_no_figures_no_row() -> None:
    assert results({}) == []
