"""Fitting the bench to recordings and to 004's figures: fit, start, replay, profile, verdict."""

from __future__ import annotations

__all__ = ['calibrate', 'calibrate_bags', 'calibrate_init', 'calibrate_profile',
           'calibrate_replay', 'calibrate_verdict']
