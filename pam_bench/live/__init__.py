"""The live view: the bench's topics served to Foxglove over its WebSocket protocol."""

from __future__ import annotations

__all__ = ['errors', 'server']
