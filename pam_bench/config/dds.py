"""The bench's Fast DDS profile, and when a process's environment names it.

``config/fastdds/discovery.xml`` makes each participant announce itself every 0.5 s (Fast
DDS's default is 3 s; docs/design.md, docs/long_runs.md "A wall-clock run's three seconds of
discovery") and each reliable writer send its heartbeat every 0.1 s while a sample is not
acknowledged (3 s; docs/long_runs.md, "The recorder missing the commands after a device's
process is killed"). Every process a run starts gets it (``bringup.common.ros_env``), and so
does the ``pam-bench`` command's own process, unless the environment already names a profile
of its own or chooses another RMW.
"""

from __future__ import annotations

import os

__all__ = ['PROFILE_VARS', 'discovery_profile_env']

PROFILE_VARS = ('FASTRTPS_DEFAULT_PROFILES_FILE', 'FASTDDS_DEFAULT_PROFILES_FILE')
"""The variables that name a Fast DDS XML profile (Fast DDS 2, Fast DDS 3)."""


def discovery_profile_env(env: dict[str, str] | os._Environ[str]) -> None:
    """Name the bench's Fast DDS profile in ``env`` (module docstring) when it names no
    profile of its own and uses Fast DDS (the default RMW); otherwise leave it as it is. Best
    effort: nothing when the file is not installed."""
    if any(env.get(v) for v in PROFILE_VARS):
        return
    if env.get('RMW_IMPLEMENTATION', 'rmw_fastrtps_cpp') != 'rmw_fastrtps_cpp':
        return
    from pam_bench.config.paths import config_dir
    try:
        path = config_dir() / 'fastdds' / 'discovery.xml'
    except FileNotFoundError:
        return
    if path.is_file():
        env[PROFILE_VARS[0]] = str(path)
