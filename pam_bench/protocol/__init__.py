"""Protocols: schedules, the sequencer state machine and its policies, ticked by node and twin."""

from __future__ import annotations

__all__ = ['io', 'runner', 'schedules', 'sequencer', 'settings', 'spec', 'suspenders', 'window']
