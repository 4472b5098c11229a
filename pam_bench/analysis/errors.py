"""Errors of offline analysis: data that cannot be extracted (a bag's own: ``bags.errors``)."""

from __future__ import annotations

from pam_bench.vocabulary.errors import PamBenchError

__all__ = ['ExtractError']


class ExtractError(PamBenchError, ValueError):
    """The bags hold too little to extract what was asked (one line saying what lacks)."""
