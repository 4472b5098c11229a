"""How nodes meet ROS: the bench node and its concepts, spin loops, the in-process bus, CDR."""

from __future__ import annotations

__all__ = ['base', 'cdr', 'core', 'diagnostics', 'faults', 'intra', 'lifecycle', 'lockstep',
           'leaving', 'messages', 'params', 'process', 'profiling', 'qos', 'scheduling', 'stamped',
           'stats', 'stepping', 'tuning', 'wallclock']
