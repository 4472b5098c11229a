"""Errors of the benchmarks: a study asked for that does not exist, a run that failed."""

from __future__ import annotations

__all__ = ['UsageError', 'StudyError']


class UsageError(ValueError):
    """A study or option that does not exist (named, with the nearest)."""


class StudyError(RuntimeError):
    """A run a study needs did not complete (the message says which and how)."""
