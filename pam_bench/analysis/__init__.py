"""Offline reading of bench bags and extraction of characteristics: no rclpy."""

from __future__ import annotations

__all__ = ['bag_repair', 'bagdiff', 'baginfo', 'bagread', 'bagwrite', 'delivery', 'errors',
           'extract', 'force_models', 'identify', 'inverse_export', 'law_scores', 'plots',
           'report', 'servo_bag', 'smoothing', 'static', 'timing', 'types']
