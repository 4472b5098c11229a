"""Errors of the live view: a server that cannot start (one line)."""

from __future__ import annotations

from pam_bench.vocabulary.errors import PamBenchError

__all__ = ['LiveViewError']


class LiveViewError(PamBenchError, OSError):
    """The live view's port is taken or its address cannot be bound."""
