"""Numpy engines that run the bench's models without ROS: the reference runs."""

from __future__ import annotations

__all__ = ['bench', 'protocol_run', 'quasistatic', 'servo_bench', 'servo_setup']
