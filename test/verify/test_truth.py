"""Quasi-static bench and `pam-bench truth`: closed forms of the parameters, self-consistency."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pam_bench.models.muscle import MuscleModel, MuscleParams
from pam_bench.models.valve import ValveModel
from pam_bench.twin.quasistatic import QuasiStaticBench
from pam_bench.verify.truth import compare, truth_summary


@pytest.fixture(scope='module')
def truth() -> dict:
    return truth_summary('campaign_quick')


@pytest.mark.parametrize('x_m', [0.0, 0.04, 0.08])
def test_position_and_force_hold_agree(x_m: float) -> None:
    """Holding the force a position hold read gives back that position (friction off)."""
    q = QuasiStaticBench(muscle=MuscleParams(hysteresis=False))
    r = q.hold_position(4.0, x_m)
    back = q.hold_force(4.0, r.force_n)
    np.testing.assert_allclose(back.contraction_m, x_m, atol=1e-9)


def test_isometric_gain_is_the_muscle_law(truth: dict) -> None:
    """Friction-free gain = k_v g(x) de/dp reduced by the belt stretch: dF/du =
    k_v g e' / (1 + K' / k_b) with K' = -g'(x) e; bounded by k_v g(x) above and, below, by the
    slope the contact band leaves at the bottom of the fitted voltages (de/dp < 1 there: the
    line through the curved foot is up to 10 % flatter at 0 mm)."""
    m = MuscleModel()
    for s in truth['isometric']['series']:
        x = s['x_mm'] * 1e-3
        g = 1e5 * m.gain(x)
        assert 0.90 * g <= s['gain_N_per_V'] <= g * 1.000001


def test_step_b_c_are_the_valve_loop(truth: dict) -> None:
    v, m = ValveModel(), MuscleModel()
    for f in truth['step_response']['fits']:
        w = v.natural_frequency(m.volume(f['x_mm'] * 1e-3))
        # evaluated at the muscle's own x (encoder x + belt stretch F / k_b, up to 0.7 mm)
        np.testing.assert_allclose([f['b'], f['c']], [2 * 0.3 * w, w * w], rtol=3e-2)
    assert len(truth['step_response']['reference_fits']) == len(truth['step_response']['fits'])


def test_hysteresis_present_and_bounded(truth: dict) -> None:
    assert 0.5 < truth['isobaric']['hysteresis_mm_max'] < 20.0


def test_truth_against_itself_is_exact(truth: dict) -> None:
    cmp = compare(truth, truth)
    assert all(r['rel_error'] == 0.0 for r in cmp['isometric_gain'])
    assert all(r[f'{c}_rel_error'] == 0.0 for r in cmp['step_fits'] for c in 'bcd')
    assert all(math.isfinite(r['b_rel_error']) for r in cmp['step_reference_fits'])


def test_truth_cli_against_an_extraction(tmp_path, capsys) -> None:
    """`pam-bench truth SCENE --against DIR --json` compares an extraction with the truth."""
    import json

    from pam_bench.cli import main as cli
    out = tmp_path / 'summary.json'
    out.write_text(json.dumps(truth_summary('isometric_quick', reference=False)))
    assert cli(['truth', 'isometric_quick', '--no-reference', '--json', '--against',
                str(tmp_path)]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data['isometric']['gain_N_per_V']['x_mm_at_max'] == 0.0
    assert all(r['rel_error'] == 0.0 for r in data['comparison']['isometric_gain'])
    assert cli(['truth', 'isometric_quick', '--against', str(tmp_path / 'none')]) == 2


@pytest.mark.slow
@pytest.mark.parametrize('scene, segments', [('straight_fibre_quick', 3),
                                             ('straight_fibre_4_quick', 4)])
def test_truth_and_twin_build_the_muscle_the_scene_names(scene: str, segments: int) -> None:
    """The scene's straight_fibre.segments reaches truth and the twin (it was dropped once:
    both built 3 segments for straight_fibre_4_quick)."""
    import subprocess
    import sys

    from pam_bench.models.straight_fibre_muscle import StraightFibreParams
    from pam_bench.verify.truth import scene_schedule
    out = subprocess.run([sys.executable, '-m', 'pam_bench.cli', 'truth', scene, '--json',
                          '--no-reference'], capture_output=True, text=True, check=True)
    import json
    t = json.loads(out.stdout)
    assert t['muscle'] == {'kind': 'straight_fibre', 'segments': segments}
    # the isotonic gains equal a bench built here with that many segments, not the other
    from pam_bench.analysis.static import gain_summary
    from pam_bench.verify.truth import _points
    mp = MuscleParams(kind='straight_fibre', hysteresis=False)
    readings = scene_schedule(scene)
    for n, same in ((segments, True), (7 - segments, False)):
        q = QuasiStaticBench(muscle=mp, straight_fibre=StraightFibreParams(segments=n,
                                                                           hysteresis=False))
        g = gain_summary(_points([(r, q.settle(r)) for r in readings]))
        want = g['isotonic']['gain_mm_per_V']['max']
        got = t['isotonic']['gain_mm_per_V']['max']
        assert (abs(got - want) < 1e-9 * want) == same, (n, got, want)
