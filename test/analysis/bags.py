"""Write small bench bags in tests with rosbags (no ROS needed)."""

from __future__ import annotations

from pam_bench.bags.bagwrite import write_bag

__all__ = ['write_bag']
