"""The data folders are found beside the package (a checkout) or in the installed share."""

from __future__ import annotations

from pam_bench.config import paths


def test_config_and_msg_defs_are_found() -> None:
    assert (paths.config_dir() / 'bench.yaml').is_file()
    assert (paths.config_dir() / 'protocols.yaml').is_file()
    assert any(paths.scenes_dir().glob('*.yaml'))
    assert (paths.msg_defs_dir() / 'ValveCommand.msg').is_file()


def test_topic_table_matches_the_recorded_step_topics() -> None:
    from pam_bench.config.topics import STEP_TOPICS, TOPICS, step_topics
    assert {t.spec for t in TOPICS} >= set(STEP_TOPICS)
    assert '/valve_2/command:pam_bench_interfaces/msg/ValveCommand' not in STEP_TOPICS
    two = step_topics(['valve_1', 'valve_2', 'torque_servo'], samples=True)
    assert '/valve_2/command:pam_bench_interfaces/msg/ValveCommand' in two
    assert '/sim/valve_1/samples:pam_bench_interfaces/msg/PressureSamples' in two
