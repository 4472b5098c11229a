"""pam-bench calibrate --target 004: the fit moves a mis-set muscle towards 004's figures; the
overlay it writes loads into a scene."""

from __future__ import annotations

import dataclasses
import pathlib

import numpy as np
import pytest

from pam_bench.config.scene import apply_overlay, load_scene
from pam_bench.config.yaml_io import ConfigError
from pam_bench.models.muscle import MuscleParams
from pam_bench.verify.calibrate import FREE, calibrate_004, residuals_004
from pam_bench.verify.figures_004 import measure_004


def test_defaults_are_at_the_fit() -> None:
    """The defaults are the fit's optimum: a nudge of any free parameter costs more."""
    base = MuscleParams()
    cost0 = float(np.sum(residuals_004(measure_004(muscle=base)) ** 2))
    for name, _, _ in FREE:
        if name == 'friction_stiffness_scale':
            continue
        worse = dataclasses.replace(base, **{name: getattr(base, name) * 1.1})
        try:
            cost = float(np.sum(residuals_004(measure_004(muscle=worse)) ** 2))
        except Exception:           # a nudge that breaks a model bound counts as worse
            continue
        assert cost > cost0, name


def test_a_few_steps_from_a_mis_set_muscle_lower_the_cost() -> None:
    base = dataclasses.replace(MuscleParams(), gain_n_per_pa=3.4e-3,
                               threshold_pressure_pa=1.0e5)
    cost0 = float(np.sum(residuals_004(measure_004(muscle=base)) ** 2)) / 2
    res = calibrate_004(base, max_nfev=3)
    assert res['cost'] < cost0
    assert set(res['stderr']) == {n for n, _, _ in FREE}
    assert len(res['correlation']) == len(FREE)


def test_overlay_goes_over_bench_yaml_and_under_the_scene(tmp_path: pathlib.Path) -> None:
    path = tmp_path / 'overlay.yaml'
    path.write_text('parameters:\n  muscle_1: {muscle: {gain_n_per_pa: 0.003, hysteresis: true}}\n'
                    '  muscle_2: {muscle: {gain_n_per_pa: 0.003}}\n')
    scene = load_scene('isometric_quick')
    scene.parameters.setdefault('muscle_1', {})['muscle'] = {'hysteresis': False}
    apply_overlay(scene, path)
    muscle = scene.parameters['muscle_1']['muscle']
    assert muscle == {'gain_n_per_pa': 0.003, 'hysteresis': False}
    assert 'muscle_2' not in scene.parameters                  # not in this scene


@pytest.mark.parametrize('text, words', [
    ('parameters:\n  muscle_1: {muscle: {gain_n_per_paa: 0.003}}\n', 'did you mean'),
    ('paramters: {}\n', "'paramters'"),
    ('parameters:\n  musle_1: {}\n', "'musle_1'"),
])
def test_a_bad_overlay_is_one_clear_error(tmp_path: pathlib.Path, text: str,
                                          words: str) -> None:
    path = tmp_path / 'overlay.yaml'
    path.write_text(text)
    with pytest.raises(ConfigError, match=words):
        apply_overlay(load_scene('isometric_quick'), path)
