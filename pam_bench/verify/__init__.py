"""What a scene's parameters imply (truth, calibration) and checks of runs against it."""

from __future__ import annotations

__all__ = ['calibration', 'prototype', 'reference_check', 'truth', 'wallclock']
