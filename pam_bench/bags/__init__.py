"""Bags in and out: reading, writing in parts, repairing, describing and comparing rosbag2 bags."""

from __future__ import annotations

__all__ = ['bag_repair', 'bagdiff', 'baginfo', 'bagread', 'bagwrite', 'errors', 'splitwriter',
           'types']
