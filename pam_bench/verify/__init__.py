"""What a scene's parameters imply (truth, calibration) and checks of runs against it."""

from __future__ import annotations

__all__ = ['calibrate', 'calibrate_bags', 'calibration', 'figures_004', 'prototype',
           'reference_check', 'truth', 'wallclock']
