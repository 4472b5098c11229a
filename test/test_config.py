"""config/bench.yaml states every model parameter, equal to the model's documented default."""

from __future__ import annotations

import pathlib

import pytest
import yaml

from pam_bench.models.loading_servo import LoadingServoParams
from pam_bench.models.muscle import MuscleParams
from pam_bench.models.params import param_infos
from pam_bench.models.sensors import EncoderParams, LoadCellParams
from pam_bench.models.torque_servo import TorqueServoParams
from pam_bench.models.valve import ValveParams
from pam_bench.sim.scene import load_scene, scene_names

CONFIG = pathlib.Path(__file__).resolve().parents[1] / 'config'


@pytest.mark.parametrize('node, prefix, cls', [
    ('valve_1', 'valve', ValveParams), ('muscle_1', 'muscle', MuscleParams),
    ('load_cell_1', 'load_cell', LoadCellParams), ('encoder', 'encoder', EncoderParams),
    ('loading_servo', 'servo', LoadingServoParams), ('valve_2', 'valve', ValveParams),
    ('muscle_2', 'muscle', MuscleParams), ('load_cell_2', 'load_cell', LoadCellParams),
    ('torque_servo', 'servo', TorqueServoParams)])
def test_bench_yaml_matches_model_defaults(node: str, prefix: str, cls: type) -> None:
    values = yaml.safe_load((CONFIG / 'bench.yaml').read_text())[node]['ros__parameters'][prefix]
    for info in param_infos(cls):
        assert info.name in values, f'{node}.{prefix}.{info.name} missing from bench.yaml'
        assert values[info.name] == pytest.approx(info.default), info.name


@pytest.mark.parametrize('name', scene_names())
def test_every_scene_loads_and_names_a_protocol(name: str) -> None:
    scene = load_scene(name)
    table = yaml.safe_load((CONFIG / 'protocols.yaml').read_text())
    assert scene.protocol in table or 'torque_servo' in scene.nodes
    assert 'Exchange step' in (CONFIG / 'scenes' / f'{name}.yaml').read_text() or name == 'demo'
