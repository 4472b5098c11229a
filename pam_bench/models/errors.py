"""Exceptions of the physics and protocol layer."""

from __future__ import annotations

__all__ = ['ModelError', 'ParameterError']


class ModelError(Exception):
    """A model was asked for something it cannot do (bad state, bad input)."""


class ParameterError(ModelError):
    """A parameter is missing, malformed or out of its range; the message names the key."""
