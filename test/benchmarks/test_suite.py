"""`pam-bench bench` report: the hand-written long-run section survives a rerun."""

from __future__ import annotations

import pytest

from pam_bench.benchmarks.suite import _long_runs


@pytest.mark.parametrize('markdown, kept', [
    ('# b\n\n## Calibration\n\nx\n\n## Long runs\n\n| a |\n', '\n## Long runs\n\n| a |\n'),
    ('# b\n\n## Long runs\n\ntext\n\n## Servo\n\ny\n', '\n## Long runs\n\ntext\n'),
    ('# b\n\n## Calibration\n\nx\n', ''),
])
def test_long_runs_section_is_kept(markdown: str, kept: str) -> None:
    assert _long_runs(markdown) == kept
