"""Fitting the bench to recordings and to 004's figures: calibration, start, replay, verdict."""

from __future__ import annotations

__all__ = ['calibrate', 'calibrate_bags', 'calibrate_init', 'calibrate_replay',
           'calibrate_verdict']
