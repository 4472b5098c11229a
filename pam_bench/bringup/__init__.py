"""Bring a scene's nodes up (separate processes or one), run it, stop it, resume it."""

from __future__ import annotations

__all__ = ['buses', 'common', 'composed', 'emulator', 'errors', 'lifecycle', 'live', 'processes',
           'provenance', 'resume', 'runner', 'wallclock']
