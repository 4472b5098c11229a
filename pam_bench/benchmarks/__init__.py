"""Benchmark studies (speed against error) and the BENCHMARKS.md report."""

from __future__ import annotations

__all__ = ['faults', 'fidelity', 'pingpong', 'record_exchange', 'sections', 'servo_compare',
           'suite', 'wallclock', 'work_precision']
