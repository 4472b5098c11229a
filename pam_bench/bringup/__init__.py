"""Bring a scene's nodes up (separate processes or one), run it, stop it, resume it."""

from __future__ import annotations

__all__ = ['emulator', 'errors', 'provenance', 'resume', 'runner']
