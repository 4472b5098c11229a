"""Where a loop on the wall clock stands among the host's processes: the SCHED_FIFO class for
the torque servo's control loop, the bus drivers and the emulated devices (no rclpy: the
emulated buses' process uses it too)."""

from __future__ import annotations

import os

__all__ = ['set_realtime_priority']


def set_realtime_priority(priority: int) -> str:
    """Put this process in the SCHED_FIFO class at ``priority`` (1..99) where the machine
    allows it (root or CAP_SYS_NICE, an rtprio limit): a loop that sleeps most of its period
    then wakes ahead of every ordinary process. Threads started afterwards inherit the class.
    Returns what happened, for the log."""
    if priority <= 0:
        return 'ordinary scheduling'
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except (PermissionError, OSError, AttributeError) as exc:
        return f'SCHED_FIFO {priority} refused ({exc}): ordinary scheduling'
    return f'SCHED_FIFO priority {priority}'
