"""000's correlation graph: exact at Table 4's 27 nodes, refuses to extrapolate; the forward
sizing tool and its JSON."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from pam_bench.models.laws.straight_fibre import PI2, PI3, TABLE4, contraction_ratio, size
from pam_bench.vocabulary.errors import ParameterError

# 000 Table 4 as printed: (Phi0 mm, L0 mm, P MPa, F N, dL/L0)
ROWS = [(30, 120, 0.2, 1, 0.433), (30, 80, 0.45, 1, 0.387), (30, 60, 0.8, 1, 0.345),
        (30, 120, 0.2, 100, 0.409), (30, 80, 0.45, 400, 0.3184), (30, 60, 0.8, 2400, 0.12),
        (30, 120, 0.2, 2400, 0.088), (30, 80, 0.45, 1200, 0.212)]


@pytest.mark.parametrize('phi, l0, p, f, ratio', ROWS)
def test_the_graph_returns_table_4_at_its_nodes(phi: float, l0: float, p: float, f: float,
                                                ratio: float) -> None:
    got = contraction_ratio(phi / l0, p * 1e6 * (l0 * 1e-3) ** 2 / f)
    np.testing.assert_allclose(got, ratio, rtol=0, atol=1e-12)


def test_every_node_exactly_and_monotone_between() -> None:
    for i, pi3 in enumerate(PI3):
        for j, pi2 in enumerate(PI2):
            assert contraction_ratio(pi2, pi3) == pytest.approx(TABLE4[i, j], abs=1e-12)
    line = [contraction_ratio(0.3, v) for v in np.geomspace(1.2, 2880, 50)]
    assert np.all(np.diff(line) >= -1e-12)            # more pressure per load: more stroke


@pytest.mark.parametrize('pi2, pi3, words', [(0.2, 100, 'Phi0/L0'), (0.3, 5000, 'P L0^2'),
                                             (0.3, 1.0, 'P L0^2')])
def test_outside_the_graph_is_refused(pi2: float, pi3: float, words: str) -> None:
    with pytest.raises(ParameterError, match=words.replace('^', r'\^')):
        contraction_ratio(pi2, pi3)


def test_forward_sizing_and_its_json() -> None:
    r = size(0.030, 0.240, 2, 0.002, 10.0, 0.2e6)      # two 120 mm segments: a node
    assert r.segment_length_m == pytest.approx(0.12)
    assert r.segment_ratio == pytest.approx(0.43)
    assert r.contraction_ratio == pytest.approx(0.43 * (1 - 0.22))
    assert r.contraction_m == pytest.approx(0.43 * 0.78 * 0.24)
    res = subprocess.run([sys.executable, '-m', 'pam_bench.cli', 'size', 'straight-fibre',
                          '--diameter-mm', '30', '--length-mm', '240', '--segments', '2',
                          '--wall-mm', '2', '--force-n', '10', '--pressure-mpa', '0.2',
                          '--json'], capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stderr
    out = json.loads(res.stdout)
    assert out['contraction_ratio'] == pytest.approx(0.43 * 0.78)
    bad = subprocess.run([sys.executable, '-m', 'pam_bench.cli', 'size', 'straight-fibre',
                          '--diameter-mm', '34', '--length-mm', '250', '--segments', '3',
                          '--wall-mm', '6', '--force-n', '10', '--pressure-mpa', '0.22'],
                         capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and 'thickness table' in bad.stderr
    assert bad.stderr.strip().count('\n') == 0


def test_inverse_designs_contract_by_the_target_when_sized_forward(tmp_path) -> None:
    from pam_bench.models.laws.straight_fibre import designs_for
    found = designs_for(50.0, 0.030, 0.2e6, 3, 0.001)
    assert len(found) >= 5
    for d in found:
        fwd = size(d.diameter_m, d.length_m, 3, 0.001, 50.0, 0.2e6)
        assert fwd.contraction_m == pytest.approx(0.030, rel=1e-6)
        assert 0.25 <= d.phi0_over_l0 <= 0.5 and 1.2 <= d.p_l0sq_over_f <= 2880
    assert designs_for(50.0, 5.0, 0.2e6, 3, 0.001) == []          # 5 m: beyond the graph
    res = subprocess.run([sys.executable, '-m', 'pam_bench.cli', 'size', 'straight-fibre',
                          '--inverse', '--force-n', '50', '--contraction-mm', '30',
                          '--pressure-mpa', '0.2', '--segments', '3', '--wall-mm', '1',
                          '--plot', str(tmp_path), '--json'], capture_output=True, text=True,
                         timeout=60)
    assert res.returncode == 0, res.stderr
    assert len(json.loads(res.stdout)) == len(found)
    assert (tmp_path / 'correlation_graph.png').stat().st_size > 10_000


@pytest.mark.parametrize('pi2', [0.25, 0.3, 0.375, 0.45, 0.5])
@pytest.mark.parametrize('pi3', [1.2, 2.0, 7.2, 50.0, 2880.0])
def test_the_force_law_reads_the_graph_backwards(pi2: float, pi3: float) -> None:
    """k = 1, r0 = 0, c = 1: F at the graph's ratio is P L0^2 / pi_3 (000 step 6)."""
    from pam_bench.models.laws import straight_fibre
    l0, p = 0.1, 2e5
    eps = contraction_ratio(pi2, pi3)
    f = straight_fibre.force(np.array([pi2, 1.0, 0.0, 0.0]), np.array([p]), np.array([eps * l0]),
                             l0)
    np.testing.assert_allclose(f, [p * l0 ** 2 / pi3], rtol=1e-9)


def test_the_correlation_column_is_continued_with_its_end_segments() -> None:
    from pam_bench.models.laws.straight_fibre import Correlation
    c = Correlation(0.3)
    lo, slope_lo = c.log_pi3(c.ratios[0] - 0.01)
    hi, slope_hi = c.log_pi3(c.ratios[-1] + 0.001)
    assert slope_lo > 0 and slope_hi > slope_lo               # the top of the graph is flat
    np.testing.assert_allclose(lo, np.log10(PI3[0]) - 0.01 * slope_lo, rtol=1e-12)
    np.testing.assert_allclose(hi, np.log10(PI3[-1]) + 0.001 * slope_hi, rtol=1e-12)
    with pytest.raises(ParameterError, match='outside the correlation graph'):
        Correlation(0.55)
