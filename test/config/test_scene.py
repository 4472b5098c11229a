"""Scenes: every scene loads; strict keys and types; settings by path; bench.yaml only overlays."""

from __future__ import annotations

import pathlib

import pytest

from pam_bench.config.errors import ConfigError
from pam_bench.config.nodes import NODES
from pam_bench.config.paths import config_dir
from pam_bench.config.protocols import load_protocols
from pam_bench.config.scene import SCENE_KEYS, bench_overlay, load_scene, scene_names
from pam_bench.vocabulary.params import flat_infos, get_path
from pam_bench.vocabulary.yaml_io import read_yaml


def _flat(d: dict, prefix: str = '') -> dict:
    out = {}
    for k, v in d.items():
        out.update(_flat(v, f'{prefix}{k}.') if isinstance(v, dict) else {prefix + k: v})
    return out


@pytest.mark.parametrize('node', sorted(bench_overlay()))
def test_bench_yaml_sets_only_what_differs_from_the_defaults(node: str) -> None:
    """One owner per default: bench.yaml may only change a value, never restate it."""
    defaults = {i.name: i.default for i in flat_infos(NODES[node].settings)}
    for key, value in _flat(bench_overlay()[node]).items():
        assert key in defaults, f'{node}.{key} is not a setting'
        assert value != defaults[key], f'{node}.{key} restates its default {value!r}'


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


def test_settings_keep_the_clock_apart_and_take_the_run() -> None:
    st = load_scene('demo').settings('/tmp/x', 3, False)
    clock = st['sim_clock']
    assert not hasattr(clock, 'lockstep') and clock.participants[0] == '/valve_1'
    assert '/sim_clock' not in clock.participants and len(clock.participants) == 7
    assert st['load_cell_1'].seed == 3 and st['recorder'].out_dir == '/tmp/x'
    assert st['sequencer'].pressure_tolerance_pa == 20000.0       # bench.yaml over the default


def test_two_channel_nodes_take_their_channel_from_the_node_table() -> None:
    st = load_scene('servo_sin_t').settings(seed=5)
    assert [st[n].channel for n in ('valve_1', 'valve_2', 'muscle_2', 'load_cell_2')] == \
        [1, 2, 2, 2]
    assert (st['load_cell_1'].seed, st['load_cell_2'].seed) == (5, 6)


@pytest.mark.parametrize('path, value', [
    ('muscle_1.muscle.gain_exponent', 1.3), ('muscle_1.straight_fibre.segments', 5),
    ('valve_1.valve.damping_ratio', 0.4), ('sequencer.stale_timeout_s', 0.25),
    ('loading_servo.servo.force_kp', 4.0), ('recorder.flush_period_s', 2.0),
    ('sim_clock.stall_timeout_s', 3.0), ('muscle_1.settle.force_n', 0.2),
])
def test_a_setting_set_by_path_reaches_the_settings(path: str, value: object) -> None:
    scene = load_scene('demo')
    scene.set(path, value)
    node, rest = path.split('.', 1)
    assert get_path(scene.settings()[node], rest) == value


@pytest.mark.parametrize('path, value, words', [
    ('muscle_1.muscle.gain_exponant', 1.3, ["'muscle_1.muscle.gain_exponent'"]),
    ('muscle_1.musle.gain_exponent', 1.3, ["'muscle_1.muscle.gain_exponent'"]),
    ('muscel_1.muscle.gain_exponent', 1.3, ["'muscle_1'"]),
    ('muscle_1.muscle', 1.3, ['is a section']),
    ('muscle_1.muscle.gain_exponent', 99.0, ['above its maximum']),
    ('valve_1.valve.scheme', 'zho', ["did you mean 'zoh'"]),
])
def test_a_bad_path_is_one_line_naming_the_nearest(path: str, value: object,
                                                   words: list[str]) -> None:
    scene = load_scene('demo')
    with pytest.raises(ConfigError) as info:
        scene.set(path, value)
    assert '\n' not in str(info.value)
    for w in words:
        assert w in str(info.value), str(info.value)


def test_a_law_named_without_kind_law_is_refused_in_one_line() -> None:
    """Naming a force law while the muscle stays the bench's McKibben used to run the default
    bench silently."""

    scene = load_scene('demo')
    with pytest.raises(ConfigError, match=r"muscle_1\.muscle\.law 'tondu_lopez' names a force "
                       r"law, but muscle_1\.muscle\.kind is 'mckibben'"):
        scene.set('muscle_1.muscle.law', 'tondu_lopez')
        scene.settings()
    scene = load_scene('demo')
    scene.set('muscle_1.muscle.kind', 'law')
    scene.set('muscle_1.muscle.law', 'tondu_lopez')
    assert scene.settings()['muscle_1'].muscle.law == 'tondu_lopez'


@pytest.mark.parametrize('name, asked, core', [
    ('demo', 'auto', 'interpreted'),              # 10 ms exchanges of 5 ms sub-steps
    ('campaign_quick', 'auto', 'compiled'),       # 3 s exchanges
    ('demo', 'compiled', 'compiled'),             # a choice is kept
    ('campaign_quick', 'interpreted', 'interpreted'),
])
def test_a_scene_decides_how_its_law_runs_before_the_run(name: str, asked: str,
                                                         core: str) -> None:
    """Every engine reads the scene's settings: one decision, so one bag."""
    scene = load_scene(name)
    scene.set('muscle_1.muscle.kind', 'law')
    scene.set('muscle_1.muscle.law', 'tondu_lopez')
    scene.set('muscle_1.muscle.law_core', asked)
    assert scene.settings()['muscle_1'].muscle.law_core == core
    plain = load_scene(name).settings()['muscle_1'].muscle      # the McKibben: untouched
    assert plain.kind == 'mckibben' and plain.law_core == 'auto'


def test_how_a_law_runs_without_kind_law_is_refused_in_one_line() -> None:
    scene = load_scene('demo')
    with pytest.raises(ConfigError, match=r"muscle_1\.muscle\.law_core 'compiled' says how a "
                       r"force law runs, but muscle_1\.muscle\.kind is 'mckibben'"):
        scene.set('muscle_1.muscle.law_core', 'compiled')
        scene.settings()


def test_a_bag_recorded_beside_a_plug_in_law_is_read_where_it_is_missing() -> None:
    """A bag recorded where a plug-in law was installed carries that law's parameter section
    (every law's parameters are settings). Where the plug-in is missing the section is left
    out, unless the muscle held that law: then one line says to install it."""
    from pam_bench.config.errors import ConfigError
    from pam_bench.config.scene import settings_of_params_file
    other = {'laws': {'sarosi': {'a': 120.0}, 'not_here_law': {'k': 1.0}},
             'muscle': {'kind': 'law', 'law': 'sarosi'}}
    st = settings_of_params_file({'muscle_1': {'ros__parameters': other}}, 'bag')
    assert st['muscle_1'].laws.sarosi.a == 120.0 and st['muscle_1'].muscle.law == 'sarosi'
    mine = {'laws': {'not_here_law': {'k': 1.0}}, 'muscle': {'kind': 'law', 'law': 'not_here_law'}}
    with pytest.raises(ConfigError, match="'not_here_law', a plug-in not installed here"):
        settings_of_params_file({'muscle_1': {'ros__parameters': mine}}, 'bag')
    with pytest.raises(ConfigError, match='not_here'):        # a user's file: still an error
        settings_of_params_file({'muscle_1': {'ros__parameters': {
            'muscle': {'not_here': 1.0}}}}, 'bag')
