"""``pam-bench params --ros-yaml``: an rcl params file for nodes started by hand, any namespace."""

from __future__ import annotations

import pathlib

import yaml

from pam_bench.config.scene import load_scene, settings_of_params_file
from test.cli.helpers import cli, one_line_error


def test_ros_yaml_keys_every_node_for_any_namespace(tmp_path: pathlib.Path) -> None:
    path = tmp_path / 'demo.yaml'
    code, out, _ = cli('params', 'demo', '--ros-yaml', path)
    assert code == 0 and 'wrote' in out
    data = yaml.safe_load(path.read_text())
    scene = load_scene('demo')
    assert set(data) == {f'/**/{n}' for n in scene.nodes}
    settings = settings_of_params_file(data)          # the keys name the scene's nodes
    assert all(not s.lockstep for s in settings.values())         # as run --wallclock
    assert settings['sequencer'].await_recorder
    assert settings['sequencer'].protocol == scene.settings()['sequencer'].protocol


def test_ros_yaml_of_one_node_on_stdout() -> None:
    code, out, _ = cli('params', 'servo_sin_t', '--ros-yaml', '--node', 'torque_servo')
    data = yaml.safe_load(out)
    assert code == 0 and list(data) == ['/**/torque_servo']
    assert data['/**/torque_servo']['ros__parameters']['duration_s'] > 0.0


def test_ros_yaml_never_replaces_a_file_it_did_not_write(tmp_path: pathlib.Path) -> None:
    mine = tmp_path / 'mine.yaml'
    mine.write_text('my: notes\n')
    line = one_line_error(*cli('params', 'demo', '--ros-yaml', mine, '--overwrite')[::2])
    assert 'not written by pam-bench' in line and mine.read_text() == 'my: notes\n'
    ours = tmp_path / 'ours.yaml'
    assert cli('params', 'demo', '--ros-yaml', ours)[0] == 0
    assert 'exists' in one_line_error(*cli('params', 'demo', '--ros-yaml', ours)[::2])
    assert cli('params', 'demo', '--ros-yaml', ours, '--overwrite')[0] == 0
