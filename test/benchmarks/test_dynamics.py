"""The dynamics study's decomposition: the voltage split against closed forms, and the twin's
identification against the model shipped from the nodes' run."""

from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.dynamics import identify, voltage_split
from pam_bench.config.paths import config_dir
from pam_bench.control.inverse import InverseModel, Poly
from pam_bench.control.torque_servo import Signal, SignalKind


def _model(b: float, c: float, d: float, f_a0: float, u0: float, k: float, f0: float
           ) -> InverseModel:
    def const(v: float) -> Poly:
        return Poly((v,), 0.0, 1.0)
    return InverseModel(const(b), const(c), const(d), const(f_a0), u0, const(k), const(f0),
                        0.0, 100.0)


SINE = Signal(SignalKind.SINE, 50.0, 1.0, 400.0)


@pytest.mark.parametrize('b, d', [(10.0, 100_000.0), (20.0, 50_000.0)])
def test_a_chord_through_the_static_line_leaves_only_the_dynamic_part(b: float, d: float
                                                                       ) -> None:
    """d / c = k and u0 on the static line: the linearised static part is the static inverse,
    and the dynamic part is (F'' + b F') / d, RMS 50 sqrt(1 + b^2) / (d sqrt 2) over a
    period."""
    c = d / 250.0
    m = _model(b, c, d, 100.0, 1.0, 250.0, -150.0)      # 1 V = (100 + 150) / 250
    out = voltage_split(m, SINE, 0.02, 2 * math.pi, h_s=1e-4)
    np.testing.assert_allclose(out['u_static_gap_rms_v'], 0.0, atol=1e-12)
    np.testing.assert_allclose(out['u_dynamic_part_rms_v'],
                               50.0 * math.sqrt(1 + b * b) / d / math.sqrt(2), rtol=1e-3)


def test_a_chord_steeper_than_the_static_line_misplaces_the_force() -> None:
    """d / c = 200 N/V against k = 250 N/V: gap(F) = 1 + (F - 100) / 200 - (F + 150) / 250,
    linear in F = 400 + 50 sin t, so its RMS is sqrt(mean^2 + (50 s / sqrt 2)^2) with slope
    s = 1/200 - 1/250."""
    m = _model(10.0, 1.0, 200.0, 100.0, 1.0, 250.0, -150.0)
    out = voltage_split(m, SINE, 0.02, 2 * math.pi, h_s=1e-4)
    mean = 1 + 300 / 200 - 550 / 250
    slope = 1 / 200 - 1 / 250
    want = math.sqrt(mean ** 2 + (50 * slope) ** 2 / 2)
    np.testing.assert_allclose(out['u_static_gap_rms_v'], want, rtol=1e-3)
    np.testing.assert_allclose(out['force_gap_rms_n'], want * 250.0, rtol=1e-3)
    assert out['chord_gain_n_per_v'] == 200.0 and out['isometric_gain_n_per_v'] == 250.0


def test_the_twin_identifies_the_model_the_nodes_did() -> None:
    """The identification scene on the twin gives the inverse model that the nodes' run gave
    (config/inverse_model.yaml): static gain and the linear model's coefficients at 20 and 50
    mm within 5 %."""
    model, step = identify({})
    shipped = InverseModel.load(config_dir() / 'inverse_model.yaml')
    assert len(step['fits']) >= 17
    for x in (0.02, 0.05):
        for name in ('k', 'b', 'c', 'd'):
            np.testing.assert_allclose(getattr(model, name)(x), getattr(shipped, name)(x),
                                       rtol=0.05, err_msg=f'{name} at {x} m')
