"""The protocol table: one loader, one error per unknown name, overrides checked by kind."""

from __future__ import annotations

import pathlib

import pytest

from pam_bench.config.errors import ConfigError
from pam_bench.config.protocols import (
    load_protocols,
    parse_overrides,
    protocol_config,
    protocol_schedule,
)
from pam_bench.vocabulary.errors import ParameterError


def test_every_protocol_of_the_table_schedules() -> None:
    table = load_protocols()
    for name in table:
        readings, settle = protocol_schedule(name, table=table)
        assert readings and settle > 0, name


@pytest.mark.parametrize('name, overrides, words', [
    ('isometrc', None, ["unknown protocol 'isometrc'", "did you mean 'isometric'"]),
    ('isometric', {'dwel_s': 2.0}, ["'dwel_s'", "did you mean 'dwell_s'"]),
    ('isometric', {'force_n': [1, 2, 1]}, ["'force_n'", 'isometric']),
    ('step_response', {'up': {'u0_v': 1.0, 'stepv': 0.2, 'n': 2}}, ["'up.stepv'", "'up.step_v'"]),
])
def test_unknown_names_give_one_error(name: str, overrides: dict | None,
                                      words: list[str]) -> None:
    with pytest.raises(ParameterError) as info:
        protocol_config(name, overrides)
    for w in words:
        assert w in str(info.value), str(info.value)


def test_overrides_merge_over_the_entry() -> None:
    readings, _ = protocol_schedule('isometric_quick', {'x_m': [0.0, 0.0, 0.01]})
    assert {r.series for r in readings} == {0}


def test_override_text_must_be_a_mapping() -> None:
    assert parse_overrides('') == {}
    assert parse_overrides('dwell_s: 1.0') == {'dwell_s': 1.0}
    with pytest.raises(ConfigError, match='mapping'):
        parse_overrides('[1, 2]')
    with pytest.raises(ConfigError, match='not valid YAML'):
        parse_overrides('a: [1,')


def test_a_table_with_an_unknown_kind_is_refused(tmp_path: pathlib.Path) -> None:
    path = tmp_path / 'protocols.yaml'
    path.write_text('mine:\n  kind: isometrik\n')
    with pytest.raises(ParameterError, match="unknown kind 'isometrik'.*'isometric'"):
        load_protocols(path)
