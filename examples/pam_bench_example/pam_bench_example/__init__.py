"""An example plug-in package for pam_bench: one force law and one controller."""

from __future__ import annotations

__all__ = ['controllers', 'laws']
