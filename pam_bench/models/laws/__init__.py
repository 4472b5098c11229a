"""Muscle laws of the seeds, one module per law, each with its equation, units and seed."""

from __future__ import annotations

__all__ = ['al_ibadi', 'base', 'bench_mckibben', 'chou_hannaford', 'kang', 'kerscher',
           'sarosi', 'straight_fibre', 'tondu_lopez', 'zoo']
