"""Parameter sweeps: a sweep file, its jobs on the execution layer, results.csv and plots."""

from __future__ import annotations

__all__ = ['figures', 'jobs', 'results', 'spec']
