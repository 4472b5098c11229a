"""Physics, controllers and protocol logic of the bench: numpy/scipy only, never rclpy."""

from __future__ import annotations

__all__ = ['errors', 'friction', 'inverse', 'loading_servo', 'lti', 'muscle', 'params',
           'protocols', 'schedules', 'sensors', 'valve']
