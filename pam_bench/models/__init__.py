"""Physics, controllers and protocol logic of the bench: numpy/scipy only, never rclpy."""

from __future__ import annotations

__all__ = ['errors', 'friction', 'loading_servo', 'lti', 'muscle', 'params', 'sensors', 'valve']
