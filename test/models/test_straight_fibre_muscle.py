"""000's straight-fibre muscle on the bench: the prototype's figures, its volume, stiffness and
hysteresis, and the kind switch."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from pam_bench.models.bench_muscle import make_muscle
from pam_bench.models.muscle import MuscleModel, MuscleParams
from pam_bench.models.straight_fibre_muscle import StraightFibreMuscle, StraightFibreParams
from pam_bench.vocabulary.errors import ParameterError

P_PA = 0.22e6           # 000 section 2.3: 2.2 bar
L_M = 0.25


def contraction_at(m: StraightFibreMuscle, force_n: float) -> float:
    return brentq(lambda x: m.static_force(P_PA, x) - force_n, 0.0, 0.2 * 1.0 + 0.05)


# (segments, load N, contraction ratio, tolerance in points): 000 section 2.3
ISOTONIC = [(3, 10.0, 0.181, 0.025), (3, 150.0, 0.148, 0.025),
            (4, 10.0, 0.153, 0.025), (4, 150.0, 0.111, 0.025)]
# (segments, contraction ratio, force N, relative tolerance)
ISOMETRIC = [(3, 0.0, 558.0, 0.25), (3, 0.144, 127.0, 0.15),
             (4, 0.0, 433.0, 0.10), (4, 0.144, 35.0, 0.15)]


@pytest.mark.parametrize('segments, load, ratio, tol', ISOTONIC)
def test_prototype_contraction_under_load(segments: int, load: float, ratio: float,
                                          tol: float) -> None:
    m = StraightFibreMuscle(StraightFibreParams(segments=segments))
    np.testing.assert_allclose(contraction_at(m, load) / L_M, ratio, atol=tol)


@pytest.mark.parametrize('segments, ratio, force, rtol', ISOMETRIC)
def test_prototype_force_at_fixed_contraction(segments: int, ratio: float, force: float,
                                              rtol: float) -> None:
    m = StraightFibreMuscle(StraightFibreParams(segments=segments))
    np.testing.assert_allclose(m.static_force(P_PA, ratio * L_M), force, rtol=rtol)


def test_printed_graph_is_what_the_sizing_tool_says() -> None:
    """k = 1 - K_S s, r0 = 0, c = 1: the bench muscle contracts as ``size`` predicts."""
    from pam_bench.models.laws.straight_fibre import size
    wall = 0.002
    sp = StraightFibreParams(free_length_m=0.3, bore_m=0.03, segments=3,
                             contraction_scale=1 - 0.11 * wall * 1e3, contraction_offset=0.0,
                             pressure_scale=1.0, hysteresis=False)
    m = StraightFibreMuscle(sp)
    for f in (2.0, 20.0, 200.0):
        want = size(0.03, 0.3, 3, wall, f, 3e5).contraction_m
        np.testing.assert_allclose(m.static_force(3e5, want), f, rtol=1e-9)


@pytest.mark.parametrize('x_m', [0.0005, 0.01, 0.03, 0.045, 0.06])
def test_stiffness_is_minus_the_slope(x_m: float) -> None:
    m = StraightFibreMuscle(StraightFibreParams(hysteresis=False))
    h = 1e-7
    slope = -(m.static_force(P_PA, x_m + h) - m.static_force(P_PA, x_m - h)) / (2 * h)
    np.testing.assert_allclose(m.trial(P_PA, x_m)[1], slope, rtol=1e-4)


def test_force_falls_with_contraction_and_grows_with_pressure() -> None:
    m = StraightFibreMuscle(StraightFibreParams(hysteresis=False))
    x = np.linspace(0.0, 0.06, 61)
    f = np.array([m.static_force(P_PA, v) for v in x])
    assert np.all(np.diff(f) <= 0.0) and f[0] > 0.0
    assert m.static_force(0.0, 0.01) == 0.0
    assert m.static_force(3e5, 0.02) > m.static_force(2e5, 0.02)
    assert m.static_force(P_PA, -0.001) == pytest.approx(f[0] + 500.0)   # k_s 5e5 N/m


def test_volume_is_the_tube_at_rest_and_grows_as_it_bulges() -> None:
    sp = StraightFibreParams()
    m = StraightFibreMuscle(sp)
    np.testing.assert_allclose(m.volume(0.0), math.pi * (sp.bore_m / 2) ** 2 * sp.free_length_m,
                               rtol=1e-12)
    v = [m.volume(x) for x in np.linspace(0.0, 0.06, 13)]
    assert np.all(np.diff(v) > 0.0)


def test_hysteresis_loop_without_chatter() -> None:
    """Pressure up and down at fixed length: the loop opens (force lower on the way up), and a
    tiny back-and-forth of the pressure makes no force jumps (no chatter)."""
    m = StraightFibreMuscle()
    m.reset(0.02, 0.0)
    ps = np.concatenate([np.linspace(0, P_PA, 45), np.linspace(P_PA, 0, 45)])
    f = np.array([m.step(p, 0.02).force_n for p in ps])
    up, down = f[:45], f[45:][::-1]
    assert np.max(down - up) > 1.0
    f0 = m.step(1e5, 0.02).force_n
    jiggle = [m.step(1e5 + d, 0.02).force_n for d in (1.0, -1.0) * 50]
    assert max(abs(j - f0) for j in jiggle) < 0.1


def test_kind_switch_and_its_message() -> None:
    assert isinstance(make_muscle(MuscleParams()), MuscleModel)
    assert isinstance(make_muscle(MuscleParams(kind='straight_fibre')), StraightFibreMuscle)
    with pytest.raises(ParameterError, match="did you mean 'straight_fibre'"):
        make_muscle(MuscleParams(kind='straight_fiber'))
    with pytest.raises(ParameterError, match='outside the correlation graph'):
        StraightFibreMuscle(dataclasses.replace(StraightFibreParams(), bore_m=0.034,
                                                segments=4))
