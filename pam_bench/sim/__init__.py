"""The simulated clock's own rules: lock-step windows and negotiation, faults to inject."""

from __future__ import annotations

__all__ = ['faults', 'lockstep']
