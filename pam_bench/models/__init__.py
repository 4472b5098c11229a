"""Physics of the bench: valve, muscles and their laws, friction, drive, sensors; never rclpy."""

from __future__ import annotations

__all__ = ['bench_muscle', 'constants', 'coupling', 'errors', 'friction', 'laws',
           'loading_servo', 'lti', 'muscle', 'sensors', 'straight_fibre_muscle',
           'valve']
