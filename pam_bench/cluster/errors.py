"""Errors of the execution layer: a cluster that cannot be reached or used."""

from __future__ import annotations

from pam_bench.vocabulary.errors import PamBenchError

__all__ = ['ClusterError']


class ClusterError(PamBenchError, RuntimeError):
    """The scheduler cannot be reached, refuses this client, or lost the work (one line)."""
