"""Errors of the execution layer: a cluster that cannot be reached or used."""

from __future__ import annotations

__all__ = ['ClusterError']


class ClusterError(RuntimeError):
    """The scheduler cannot be reached, refuses this client, or lost the work (one line)."""
