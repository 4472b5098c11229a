"""Extraction from small synthetic bags: known gains and step coefficients, bad input."""

from __future__ import annotations

import json
import pathlib

import numpy as np
import pytest

from pam_bench.analysis.extract import extract
from pam_bench.bags.bagread import read_bags
from pam_bench.bags.errors import BagError
from pam_bench.cli import main as cli
from pam_bench.control.inverse import InverseModel
from test.analysis.bags import write_bag
from test.analysis.test_identify import synth


def isometric_points(gains: dict[float, float]) -> list[dict]:
    pts = []
    volts = np.arange(0.0, 6.01, 0.5)
    for s, (x, k) in enumerate(gains.items()):
        seq = [(0, u) for u in volts] + [(1, u) for u in volts[::-1]]
        for step, (d, u) in enumerate(seq):
            f = max(k * (u - 0.2), 0.0) + (-3.0 if d == 0 else 3.0) * (u > 0.2)
            pts.append(dict(protocol='isometric', series=s, step=step, direction=d,
                            series_value=x, set_value=u, voltage=u, force=f, contraction=x,
                            pressure=1e5 * u))
    return pts


@pytest.mark.slow
def test_isometric_gains_recovered(tmp_path: pathlib.Path) -> None:
    gains = {0.0: 284.3, 0.05: 95.0, 0.095: 17.4}
    write_bag(tmp_path / 'bag', isometric_points(gains))
    s = extract([str(tmp_path / 'bag')], str(tmp_path / 'out'))
    g = s['isometric']['gain_N_per_V']
    np.testing.assert_allclose([g['max'], g['min']], [284.3, 17.4], rtol=1e-3)
    assert (g['x_mm_at_max'], g['x_mm_at_min']) == pytest.approx((0.0, 95.0))
    assert json.loads((tmp_path / 'out' / 'summary.json').read_text())['isometric']
    assert (tmp_path / 'out' / 'isometric.csv').exists()


@pytest.mark.slow
def test_step_coefficients_and_polynomials(tmp_path: pathlib.Path) -> None:
    recs = []
    truth = {}
    for s, x in enumerate([0.0, 0.02, 0.04, 0.06, 0.08]):
        b, c, d = 18.8 - 80 * x, 986.0 - 4000 * x, 2.8e4 - 2e5 * x
        truth[round(x * 1e3)] = (b, c, d)
        f = synth(b, c, d, 300.0 - 1000 * x, 4.0, delay=3)
        recs.append(dict(series=s, step=0, direction=0, contraction=x, voltage_initial=1.0,
                         voltage_final=5.0, sample_period=0.001, force=f))
    write_bag(tmp_path / 'bag', isometric_points({0.0: 284.3, 0.04: 120.0}), recs)
    s = extract([str(tmp_path / 'bag')], str(tmp_path / 'out'))
    for fit in s['step_response']['fits']:
        np.testing.assert_allclose([fit['b'], fit['c'], fit['d']], truth[round(fit['x_mm'])],
                                   rtol=1e-4)
    poly = s['step_response']['polynomials']['b']
    assert poly['degree'] == 4 and poly['rms_residual'] < 1e-3
    # the inverse model the servo loads: b(x) as identified, static inverse of the lines
    inv = InverseModel.load(tmp_path / 'out' / 'inverse_model.yaml')
    np.testing.assert_allclose(inv.b(0.04), truth[40][0], rtol=1e-3)
    f_set = 120.0 * 3.0 - 0.2 * 120.0          # the isometric line at x = 40 mm, u = 3 V
    np.testing.assert_allclose(inv.static_voltage(f_set, 0.04), 3.0, rtol=1e-6)
    out = tmp_path / 'out'
    assert {m['model'] for m in s['model_comparison']} >= {'chou_hannaford', 'sarosi'}
    # each branch fitted apart (002 Fig. 11): a fit to one branch is at least as close to it
    # as the pooled fit, whose RMSE over both branches bounds the better branch's from above
    branches = {m['model']: m for m in s['model_comparison_by_branch']}
    pooled = {m['model']: m['rmse_N'] for m in s['model_comparison']}
    assert set(branches) == set(pooled)
    for name, b in branches.items():
        assert min(b['loading_rmse_N'], b['unloading_rmse_N']) <= pooled[name] * 1.001 + 1e-6
    for name in s['figures']:
        assert (out / name).stat().st_size > 1000 and f'({name})' in (
            out / 'report.md').read_text()


@pytest.mark.parametrize('make, message', [
    (lambda p: None, 'no such bag'),
    (lambda p: p.write_text('not a bag'), 'not a rosbag2 directory'),
    (lambda p: p.mkdir(), 'no metadata.yaml'),
])
def test_bad_paths_one_clear_message(tmp_path: pathlib.Path, make, message: str) -> None:
    bag = tmp_path / 'bag'
    make(bag)
    with pytest.raises(BagError, match=message):
        read_bags([bag])


def test_truncated_bag(tmp_path: pathlib.Path, capsys: pytest.CaptureFixture) -> None:
    write_bag(tmp_path / 'bag', isometric_points({0.0: 284.3}))
    mcap = next((tmp_path / 'bag').glob('*.mcap'))
    mcap.write_bytes(mcap.read_bytes()[:200])
    assert cli(['extract', str(tmp_path / 'bag'), '--out', str(tmp_path / 'out')]) == 2
    err = capsys.readouterr().err
    assert err.startswith('error:') and 'Traceback' not in err
    assert not (tmp_path / 'out').exists()                     # nothing half-written


def test_bag_without_points(tmp_path: pathlib.Path, capsys: pytest.CaptureFixture) -> None:
    write_bag(tmp_path / 'bag', [])
    assert cli(['extract', str(tmp_path / 'bag'), '--out', str(tmp_path / 'out')]) == 2
    assert 'no protocol points' in capsys.readouterr().err
    assert not (tmp_path / 'out').exists()


def test_too_few_points_to_fit(tmp_path: pathlib.Path, capsys: pytest.CaptureFixture) -> None:
    pts = isometric_points({0.0: 284.3})[:1]
    write_bag(tmp_path / 'bag', pts)
    assert cli(['extract', str(tmp_path / 'bag'), '--out', str(tmp_path / 'out')]) == 2
    assert 'too few points' in capsys.readouterr().err
    assert not (tmp_path / 'out').exists()


def test_polynomials_in_mm_and_m_agree() -> None:
    """The same smoothing in mm (summary.json) and in m (inverse_model.yaml): the centred and
    scaled z makes the coefficients identical, and both evaluate to the same value."""
    from pam_bench.analysis.extract import coefficient_polynomials
    from pam_bench.analysis.inverse_export import smoothing_polynomial
    from pam_bench.control.inverse import Poly
    x_mm = np.arange(0.0, 85.0, 5.0)
    y = 18.8 - 0.08 * x_mm + 3e-4 * x_mm ** 2 + 1e-7 * x_mm ** 5
    fits = [{'x_mm': x, 'direction': 'up', 'u1_V': 5.0, 'b': v, 'c': 1.0, 'd': 1.0,
             'F_a0_N': 1.0} for x, v in zip(x_mm, y, strict=True)]
    in_mm = coefficient_polynomials(fits)['b']
    in_m = smoothing_polynomial(x_mm * 1e-3, y)
    np.testing.assert_allclose(in_mm['coefficients_low_to_high'],
                               in_m['coefficients_low_to_high'], rtol=1e-9, atol=1e-12)
    p = Poly.from_dict(in_m)
    for x in (0.0, 12.5, 80.0):
        z = (x - in_mm['x_mid_mm']) / in_mm['x_half_range_mm']
        np.testing.assert_allclose(
            p(x * 1e-3), np.polynomial.polynomial.polyval(z, in_mm['coefficients_low_to_high']),
            rtol=1e-12)
