"""Errors of the configuration layer (scenes, protocols, overlays, params files)."""

from __future__ import annotations

from pam_bench.vocabulary.errors import ParameterError

__all__ = ['ConfigError']


class ConfigError(ParameterError):
    """A configuration file or value is missing, malformed, unknown or out of range."""
