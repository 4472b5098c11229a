"""pam_bench: a ROS 2 pneumatic-muscle test bench after Pietrala and Laski 2022 (seed 004)."""

from __future__ import annotations

__all__ = ['__version__']
__version__ = '0.1.0'
