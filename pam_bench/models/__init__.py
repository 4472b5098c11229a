"""Physics, controllers, protocol logic and lock-step rules of the bench: never rclpy."""

from __future__ import annotations

__all__ = ['bench_muscle', 'constants', 'coupling', 'errors', 'faults', 'friction', 'inverse',
           'laws', 'loading_servo', 'lockstep', 'lti', 'muscle', 'params', 'protocol_io',
           'protocols', 'schedules', 'sensors', 'straight_fibre_muscle', 'suspenders',
           'torque_servo', 'valve']
