"""Quasi-static bench with the valve's overshoot against the time-stepped twin."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pam_bench.models.loading_servo import LoadMode
from pam_bench.models.muscle import MuscleParams
from pam_bench.models.sensors import LoadCellParams
from pam_bench.models.valve import ValveParams
from pam_bench.twin.bench import SingleMuscleBench
from pam_bench.twin.quasistatic import QuasiStaticBench

STAIRCASE_V = (1.0, 3.0, 6.0, 4.0, 2.0, 0.0)


@pytest.mark.parametrize('x_m, damping', [(0.0, 0.30), (0.0, 0.15), (0.04, 0.30)])
def test_isometric_staircase_lands_where_the_twin_does(x_m: float, damping: float) -> None:
    """At held encoder x the pressure's overshoot turning points move the muscle end with the
    belt stretch (x_t = x + F / k_b) at each turning point, as the twin's does; the settled
    forces then agree within 0.5 N. Committing the turning points at the previous x_t instead
    left the loop up to 28 N wider than the twin's on a drawn parameter set. The first step
    from the slack muscle differs by up to 5 N: the drive's position loop gives way while the
    force rises from zero and takes the friction part of the way back, which the ideal hold
    leaves out. Back at 0 V the pressure is under the contact threshold and what is left is the
    braid friction's residual (2 to 3 N), which the same give reaches to within 1 N."""
    valve = dataclasses.replace(ValveParams(), damping_ratio=damping)
    muscle = MuscleParams()
    twin = SingleMuscleBench(valve, muscle, LoadCellParams(noise=False))
    twin.command_load(LoadMode.POSITION, x_m, now=True)
    twin.run(3.0, 3.0)
    qs = QuasiStaticBench(valve, muscle, overshoot=True)
    qs.hold_position(0.0, x_m)
    got, want = [], []
    for u in STAIRCASE_V:
        twin.command_valve(u)
        want.append(twin.run(3.0, 3.0).force_n)
        got.append(qs.hold_position(u, x_m).force_n)
    np.testing.assert_allclose(got[0], want[0], atol=5.0)
    np.testing.assert_allclose(got[1:-1], want[1:-1], atol=0.5)
    np.testing.assert_allclose(got[-1], want[-1], atol=1.0)

