"""The calibrate study's sets: one per drawn parameter at an end of its fit interval."""

from __future__ import annotations

import dataclasses

import pytest

from pam_bench.benchmarks.calibrate import DRAWN, edge_parameters
from pam_bench.models.muscle import MuscleParams
from pam_bench.models.valve import ValveParams
from pam_bench.verify.calibrate_bags import FREE_BAGS


@pytest.mark.parametrize('k', range(len(DRAWN)))
def test_an_edge_set_moves_one_parameter_to_an_end_of_its_interval(k: int) -> None:
    valve, muscle, what = edge_parameters(k)
    name = DRAWN[k]
    model, _, lo, hi = next(row for row in FREE_BAGS if row[1] == name)
    changed = {(m, f.name) for m, obj, ref in (('valve', valve, ValveParams()),
                                               ('muscle', muscle, MuscleParams()))
               for f in dataclasses.fields(obj) if getattr(obj, f.name) != getattr(ref, f.name)}
    assert changed <= {(model, name)}
    value = getattr(valve if model == 'valve' else muscle, name)
    assert value == (lo if k % 2 == 0 else hi)
    assert name in what and ('lower' in what) == (k % 2 == 0)


def test_every_drawn_parameter_reaches_an_end_once() -> None:
    names = [edge_parameters(k)[2].split(' ')[0] for k in range(len(DRAWN))]
    assert sorted(names) == sorted(DRAWN)
