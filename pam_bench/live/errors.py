"""Errors of the live view: a server that cannot start (one line)."""

from __future__ import annotations

__all__ = ['LiveViewError']


class LiveViewError(OSError):
    """The live view's port is taken or its address cannot be bound."""
