"""The one list of benchmark studies, in the order `pam-bench bench` runs and reports them."""

from __future__ import annotations

from pam_bench.benchmarks import (
    buses,
    calibrate,
    calibrate_bounds,
    calibrate_nodes,
    dynamics,
    exchange_step,
    faults,
    figures_004,
    fuzz,
    layouts,
    lockstep,
    numerics,
    profile,
    record_exchange,
    scenes,
    servo_compare,
    settle,
    soak,
    straight_fibre,
    sweep_scaling,
    wallclock,
)
from pam_bench.benchmarks.study import Study

__all__ = ['STUDIES', 'study']

STUDIES: tuple[Study, ...] = (
    figures_004.STUDY, lockstep.STUDY, layouts.STUDY, profile.STUDY, exchange_step.STUDY,
    settle.STUDY, record_exchange.STUDY, scenes.STUDY, numerics.STUDY, wallclock.STUDY,
    faults.STUDY, straight_fibre.STUDY, calibrate.STUDY, calibrate_bounds.STUDY,
    calibrate_nodes.STUDY,
    servo_compare.STUDY, soak.STUDY, sweep_scaling.STUDY, dynamics.STUDY, fuzz.STUDY,
    buses.STUDY)
"""Every study; ``pam-bench bench --only KEY`` runs some."""


def study(key: str) -> Study:
    """The study called ``key``.

    Raises:
        KeyError: no such study.
    """
    return {s.key: s for s in STUDIES}[key]
