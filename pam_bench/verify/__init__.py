"""What a scene's parameters imply (truth, 004's figures) and checks of runs against it."""

from __future__ import annotations

__all__ = ['calibration', 'figures_004', 'prototype', 'reference_check', 'truth', 'wallclock']
