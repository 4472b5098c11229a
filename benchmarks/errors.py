"""Errors of the benchmarks: a study asked for that does not exist, a run that failed."""

from __future__ import annotations

from pam_bench.vocabulary.errors import PamBenchError

__all__ = ['UsageError']


class UsageError(PamBenchError, ValueError):
    """A study or option that does not exist (named, with the nearest)."""
