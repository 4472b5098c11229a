"""Strict YAML reading: one ``ConfigError`` naming the file and the problem, never a traceback."""

from __future__ import annotations

import pathlib
from typing import Any

import yaml

from pam_bench.config.errors import ConfigError

__all__ = ['read_yaml', 'parse_yaml']


def parse_yaml(text: str, where: str) -> dict[str, Any]:
    """Parse YAML text that must hold a mapping (empty text: an empty mapping).

    Raises:
        ConfigError: not valid YAML, or not a mapping at the top level.
    """
    try:
        data = yaml.safe_load(text) or {}
    except yaml.YAMLError as exc:
        raise ConfigError(f'{where}: not valid YAML: {str(exc).splitlines()[0]}') from None
    if not isinstance(data, dict):
        raise ConfigError(f'{where}: expected a mapping at the top level')
    return data


def read_yaml(path: pathlib.Path) -> dict[str, Any]:
    """Read a YAML file that holds a mapping.

    Raises:
        ConfigError: the file is missing, unreadable, not YAML or not a mapping.
    """
    try:
        text = path.read_text(encoding='utf-8')
    except OSError as exc:
        raise ConfigError(f'{path}: cannot read: {exc.strerror}') from None
    return parse_yaml(text, str(path))
