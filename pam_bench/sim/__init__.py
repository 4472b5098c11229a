"""Sim clock, lock-step exchange, scenes and the runner that brings them up."""

from __future__ import annotations

__all__ = ['bench', 'bench_sections', 'benchmark', 'calibration', 'fidelity', 'pingpong',
           'quasistatic', 'record_exchange', 'runner', 'scene', 'servo_bench', 'servo_compare',
           'truth', 'work_precision']
