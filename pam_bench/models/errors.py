"""Errors of the physics layer."""

from __future__ import annotations

from pam_bench.vocabulary.errors import PamBenchError

__all__ = ['ModelError']


class ModelError(PamBenchError, ValueError):
    """A model was asked for something it cannot do (bad state, bad input)."""
