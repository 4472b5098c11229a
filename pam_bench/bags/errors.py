"""Errors of bags: one that cannot be read or written, a disk too full for one."""

from __future__ import annotations

from pam_bench.vocabulary.errors import PamBenchError

__all__ = ['BagError', 'DiskFull']


class BagError(PamBenchError, ValueError):
    """A bag is missing, unreadable or holds something else than a bench bag (one line)."""


class DiskFull(PamBenchError, OSError):
    """The disk holding a bag has less free space than the writer keeps in reserve, or cannot
    hold a bag at all (a pseudo-file system)."""
