"""Offline extraction of characteristics and models from bench bags: no rclpy."""

from __future__ import annotations

__all__ = ['batch', 'delivery', 'errors', 'extract', 'force_models', 'identify',
           'inverse_export', 'law_scores', 'plots', 'report', 'servo_bag', 'smoothing',
           'static', 'timing']
