"""The one list of benchmark studies, in the order `make bench` runs and reports them."""

from __future__ import annotations

from benchmarks import (
    buses,
    calibrate,
    calibrate_bounds,
    calibrate_nodes,
    calibrate_zoo,
    calibration,
    dynamics,
    exchange_step,
    faults,
    fuzz,
    layouts,
    limits,
    lockstep,
    models,
    plugin_law,
    profile,
    record_exchange,
    scenes,
    servo_compare,
    settle,
    side_by_side,
    soak,
    straight_fibre,
    sweep_scaling,
    wallclock,
)
from benchmarks.study import Study

__all__ = ['STUDIES', 'study']

STUDIES: tuple[Study, ...] = (
    calibration.STUDY, lockstep.STUDY, layouts.STUDY, limits.STUDY, profile.STUDY,
    exchange_step.STUDY,
    settle.STUDY, record_exchange.STUDY, scenes.STUDY, models.STUDY, wallclock.STUDY,
    faults.STUDY, straight_fibre.STUDY, calibrate.STUDY, calibrate_bounds.STUDY,
    calibrate_nodes.STUDY, calibrate_zoo.STUDY, plugin_law.STUDY, side_by_side.STUDY,
    servo_compare.STUDY, soak.STUDY, sweep_scaling.STUDY, dynamics.STUDY, fuzz.STUDY,
    buses.STUDY)
"""Every study; ``python -m benchmarks --only KEY`` runs some."""


def study(key: str) -> Study:
    """The study called ``key``.

    Raises:
        KeyError: no such study.
    """
    return {s.key: s for s in STUDIES}[key]
