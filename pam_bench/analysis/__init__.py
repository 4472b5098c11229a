"""Offline reading of bench bags and extraction of characteristics: no rclpy."""

from __future__ import annotations

__all__ = ['bag_repair', 'bagdiff', 'baginfo', 'bagread', 'bagwrite', 'delivery', 'extract',
           'force_models', 'identify', 'inverse_export', 'plots', 'report',
           'servo_bag', 'smoothing', 'static', 'timing', 'types']
