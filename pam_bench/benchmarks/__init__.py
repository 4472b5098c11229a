"""Benchmark studies (speed against error) and the BENCHMARKS.md report."""

from __future__ import annotations

__all__ = ['calibrate', 'calibrate_nodes', 'faults', 'fidelity', 'pingpong', 'profile',
           'record_exchange', 'report', 'sections', 'servo_compare', 'straight_fibre', 'suite',
           'wallclock', 'work_precision']
