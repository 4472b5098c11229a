"""Errors of bringing a scene up: a run that cannot be laid out as asked."""

from __future__ import annotations

from pam_bench.vocabulary.errors import PamBenchError

__all__ = ['LayoutError', 'DomainInUseError']


class LayoutError(PamBenchError, ValueError):
    """The scene and the flags ask for a layout that cannot run (the message says why)."""


class DomainInUseError(PamBenchError, RuntimeError):
    """Another run holds what this run would use of its ROS domain (``bringup.domains``)."""
