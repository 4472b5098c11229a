"""Sim clock, lock-step exchange, scenes and the runner that brings them up."""

from __future__ import annotations

__all__ = ['bench', 'benchmark', 'calibration', 'pingpong', 'quasistatic', 'runner', 'scene',
           'truth']
