"""Scenes: bench.yaml states every model parameter; every scene loads; strict keys and types."""

from __future__ import annotations

import pathlib

import pytest

from pam_bench.config.paths import config_dir
from pam_bench.config.protocols import load_protocols
from pam_bench.config.scene import NODE_TYPES, SCENE_KEYS, load_scene, scene_names
from pam_bench.config.yaml_io import ConfigError, read_yaml
from pam_bench.models.params import param_infos

MODEL_SECTIONS = [(node, prefix, cls) for node, t in NODE_TYPES.items()
                  for prefix, cls in t.models]


@pytest.mark.parametrize('node, prefix, cls', MODEL_SECTIONS,
                         ids=[f'{n}.{p}' for n, p, _ in MODEL_SECTIONS])
def test_bench_yaml_matches_model_defaults(node: str, prefix: str, cls: type) -> None:
    values = read_yaml(config_dir() / 'bench.yaml')[node]['ros__parameters'][prefix]
    for info in param_infos(cls):
        assert info.name in values, f'{node}.{prefix}.{info.name} missing from bench.yaml'
        assert values[info.name] == pytest.approx(info.default), info.name


@pytest.mark.parametrize('name', scene_names())
def test_every_scene_loads_and_names_a_protocol(name: str) -> None:
    scene = load_scene(name)
    assert scene.protocol in load_protocols() or 'torque_servo' in scene.nodes
    text = (config_dir() / 'scenes' / f'{name}.yaml').read_text()
    assert 'Exchange step' in text or name == 'demo'


BASE = ('description: test\nexchange_step_s: 0.01\nprotocol: demo_short\n'
        'nodes: [valve_1, muscle_1, load_cell_1, encoder, loading_servo, sequencer]\n')


@pytest.mark.parametrize('extra, words', [
    ('parameters: {muscle_1: {muscle: {gain_exponnent: 2.0}}}',
     ["'muscle_1.muscle.gain_exponnent'", "did you mean 'muscle_1.muscle.gain_exponent'"]),
    ('parameters: {muscle_1: {muscle: {gain_exponent: abc}}}',
     ["'muscle_1.muscle.gain_exponent'", 'expected a number']),
    ('parameters: {valve_1: {valve: {order: 7}}}', ["'valve_1.valve.order'", 'maximum']),
    ('parameters: {musle_1: {channel: 1}}', ["'musle_1'", "did you mean 'muscle_1'"]),
    ('exchange_stepp_s: 0.01', ["'exchange_stepp_s'", "did you mean 'exchange_step_s'"]),
    ('record_samples: yes please', ["'record_samples'", 'true or false']),
    ('protocol_overrides: {dwel_s: 1.0}', ["'dwel_s'", "did you mean 'dwell_s'"]),
    ('sub_step_s: 5.0', ['sub_step_s', 'out of']),
])
def test_a_bad_scene_gives_one_line_naming_the_key(tmp_path: pathlib.Path, extra: str,
                                                  words: list[str]) -> None:
    path = tmp_path / 'bad.yaml'
    path.write_text(BASE + extra + '\n')
    with pytest.raises(ConfigError) as info:
        load_scene(str(path))
    message = str(info.value)
    assert '\n' not in message and message.startswith('scene bad.yaml')
    for w in words:
        assert w in message, message


def test_a_wrongly_typed_exchange_step_names_key_and_type(tmp_path: pathlib.Path) -> None:
    path = tmp_path / 'bad.yaml'
    path.write_text(BASE.replace('0.01', 'abc'))
    with pytest.raises(ConfigError, match="key 'exchange_step_s' must be a number of seconds"):
        load_scene(str(path))


def test_unknown_scene_and_node_suggest_the_nearest(tmp_path: pathlib.Path) -> None:
    with pytest.raises(ConfigError, match="did you mean 'isometric_quick'"):
        load_scene('isometric_quik')
    path = tmp_path / 'bad.yaml'
    path.write_text(BASE.replace('encoder,', 'encodr,'))
    with pytest.raises(ConfigError, match="unknown node 'encodr' \\(did you mean 'encoder'\\?\\)"):
        load_scene(str(path))


def test_scene_keys_cover_every_scene_file() -> None:
    for name in scene_names():
        assert set(read_yaml(config_dir() / 'scenes' / f'{name}.yaml')) <= set(SCENE_KEYS)


def test_node_parameters_keep_the_clock_apart() -> None:
    params = load_scene('demo').node_parameters('/tmp/x', 3, False)
    clock = params['sim_clock']['ros__parameters']
    assert 'lockstep' not in clock and clock['participants'][0] == '/valve_1'
    assert params['load_cell_1']['ros__parameters']['seed'] == 3
    assert params['recorder']['ros__parameters']['out_dir'] == '/tmp/x'
