"""Errors of offline analysis: bags that cannot be read, data that cannot be extracted."""

from __future__ import annotations

__all__ = ['BagError', 'ExtractError']


class BagError(ValueError):
    """A bag is missing, unreadable or holds something else than a bench bag (one line)."""


class ExtractError(ValueError):
    """The bags hold too little to extract what was asked (one line saying what lacks)."""
