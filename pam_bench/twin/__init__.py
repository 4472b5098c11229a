"""Numpy engines that run the bench's models without ROS: the reference runs."""

from __future__ import annotations

__all__ = ['bench', 'buses', 'protocol_run', 'quasistatic', 'serve_buses', 'servo_bench',
           'servo_setup']
