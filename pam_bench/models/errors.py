"""Errors of the physics layer; every later layer's errors build on them or on a builtin."""

from __future__ import annotations

__all__ = ['ModelError', 'ParameterError']


class ModelError(ValueError):
    """A model was asked for something it cannot do (bad state, bad input)."""


class ParameterError(ModelError):
    """A setting is unknown, malformed or out of its range; the message names its path."""
