"""The torque servo's control laws: inverse models of the muscle and the PID, without ROS."""

from __future__ import annotations

__all__ = ['inverse', 'torque_servo']
