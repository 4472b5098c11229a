"""The fuzz study reads hypothesis' statistics: cases per test."""

from __future__ import annotations

from benchmarks.fuzz import parse_statistics

OUT = """============================ Hypothesis Statistics =============================
test/cli/test_fuzz.py::test_fuzzed_scenes_end_cleanly:

  - during generate phase (3.40 seconds):
    - Typical runtimes: ~ 1-13 ms, of which ~ 0-7 ms in data generation
    - 300 passing, 0 failing, and 16 invalid test cases

test/cli/test_fuzz.py::test_fuzzed_bags_end_cleanly:

  - during reuse phase (0.10 seconds):
  - during generate phase (9.1 seconds):
    - 58 passing, 2 failing, and 0 invalid test cases
"""


def test_counts_per_test() -> None:
    assert parse_statistics(OUT) == [
        {'test': 'test_fuzzed_scenes_end_cleanly', 'passing': 300, 'failing': 0, 'invalid': 16},
        {'test': 'test_fuzzed_bags_end_cleanly', 'passing': 58, 'failing': 2, 'invalid': 0}]
    assert parse_statistics('no statistics here') == []
