"""The protocol table (config/protocols.yaml) and a protocol's schedule with overrides.

One loader for every reader (sequencer node, twin, truth, resume): a protocol name that is not
in the table, an override key the protocol's kind does not take, or a malformed value gives
one ``ParameterError`` naming it.
"""

from __future__ import annotations

import pathlib
from collections.abc import Mapping
from typing import Any

from pam_bench.config.errors import ConfigError
from pam_bench.config.paths import config_dir
from pam_bench.protocol.schedules import Reading, schedule_from_config
from pam_bench.protocol.spec import check_protocol
from pam_bench.vocabulary.errors import InputError
from pam_bench.vocabulary.params import hint
from pam_bench.vocabulary.yaml_io import parse_yaml, read_yaml

__all__ = ['load_protocols', 'protocol_config', 'protocol_schedule', 'parse_overrides']


def load_protocols(path: str | pathlib.Path | None = None) -> dict[str, Any]:
    """The protocol table: name -> entry (config/protocols.yaml unless ``path``).

    Raises:
        ConfigError: unreadable file, or an entry that is not a valid protocol (named).
    """
    table = read_yaml(pathlib.Path(path) if path else config_dir() / 'protocols.yaml')
    for name, entry in table.items():
        if not isinstance(entry, dict):
            raise ConfigError(f'protocol {name!r}: expected a mapping')
        check_protocol(name, entry)
    return table


def parse_overrides(text: str) -> dict[str, Any]:
    """A protocol override mapping from YAML text (a node parameter or a goal field).

    Raises:
        ConfigError: not YAML, not a mapping, too long, or a duplicate key (one line).
    """
    try:
        return parse_yaml(text, 'protocol overrides')
    except InputError as exc:
        raise ConfigError(str(exc)) from None


def protocol_config(name: str, overrides: Mapping[str, Any] | None = None,
                    table: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The entry of protocol ``name`` with ``overrides`` merged over it, checked.

    Raises:
        ConfigError: an unknown protocol (with the nearest known name) or an override key the
            protocol's kind does not take.
    """
    table = load_protocols() if table is None else table
    if name not in table:
        raise ConfigError(f'unknown protocol {name!r} ({hint(name, table)})')
    cfg = dict(table[name])
    cfg.update(overrides or {})
    check_protocol(name, cfg)
    return cfg


def protocol_schedule(name: str, overrides: Mapping[str, Any] | None = None,
                      table: Mapping[str, Any] | None = None) -> tuple[list[Reading], float]:
    """Readings and settle time (s) of protocol ``name`` with ``overrides`` (see
    ``protocol.schedules.schedule_from_config``)."""
    table = load_protocols() if table is None else table
    return schedule_from_config(name, protocol_config(name, overrides, table), table)
