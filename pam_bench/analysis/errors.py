"""Errors of bags and offline analysis: bags that cannot be read or written, data that cannot be
extracted."""

from __future__ import annotations

from pam_bench.vocabulary.errors import PamBenchError

__all__ = ['BagError', 'ExtractError', 'DiskFull']


class BagError(PamBenchError, ValueError):
    """A bag is missing, unreadable or holds something else than a bench bag (one line)."""


class ExtractError(PamBenchError, ValueError):
    """The bags hold too little to extract what was asked (one line saying what lacks)."""


class DiskFull(PamBenchError, OSError):
    """The disk holding a bag has less free space than the writer keeps in reserve, or cannot
    hold a bag at all (a pseudo-file system)."""
