"""The limit table's twin and physics figures are measured."""

from __future__ import annotations

from benchmarks.limits import physics_share, twin_run_s


def test_the_twin_and_its_physics_share_are_measured() -> None:
    """The demo on the twin takes time, and the physics is a share of it, neither none nor
    all (the sequencer and the twin's loop are Python around it)."""
    assert twin_run_s('demo') > 0.0
    share = physics_share('demo')
    assert 0.05 < share < 0.95, share
