"""Study ``side_by_side``: its table and its key row from the runs' times."""

from __future__ import annotations

from benchmarks.side_by_side import results, section

TIMES = {'base': '7e50f37', 'scenes': {
    'demo': {'times': {'base': [1.5, 1.6, 1.4], 'now': [1.0, 0.9, 1.1]}, 'goal': 1.5,
             'readings': 'identical'},
    'campaign': {'times': {'base': [25.0, 24.0, 26.0], 'now': [22.0, 21.0, 23.0]},
                 'goal': 2.0, 'readings': 'differ'}}}
REPORT = {'side_by_side': TIMES, 'measured': {'side_by_side': {'commit': 'abc1234'}}}


def test_the_speed_up_is_of_the_medians() -> None:
    lines = section(REPORT)
    demo = next(ln for ln in lines if ln.startswith('| demo'))
    assert '1.40-1.60 s (median 1.50 s)' in demo and '(median 1.00 s)' in demo
    assert '| 1.50x |' in demo and demo.rstrip(' |').endswith('identical'), demo
    campaign = next(ln for ln in lines if ln.startswith('| campaign'))
    assert '| 1.14x |' in campaign and campaign.rstrip(' |').endswith('differ'), campaign
    (row,) = results(REPORT)
    assert row[1] == 'demo 1.5x, campaign 2.0x' and row[2] == 'demo 1.50x, campaign 1.14x', row
    assert row[3] == '`abc1234`' or 'abc1234' in row[3]


def test_no_figures_no_row() -> None:
    assert results({}) == []
