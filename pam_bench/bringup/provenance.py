"""How a run was made, for the bag to carry (``bags.baginfo`` reads it back).

``run_description`` gathers the scene (name and file text), the resolved parameters of every
node, the seed, the command line, the layout, the project commit with a dirty flag, the
versions of pam_bench, rclpy, rosbags and numpy, the host and the start time. ``end_state``
turns a run's exit code into how it ended; the runner writes it to the recorder's ``end_file``
just before stopping it, so the bag closes with it.
"""

from __future__ import annotations

import datetime
import importlib.metadata
import json
import platform
import socket
import subprocess
import sys
from typing import Any

from pam_bench.config.paths import config_dir
from pam_bench.config.scene import Scene

__all__ = ['run_description', 'end_state', 'write_end', 'project_commit']

STATES = {0: 'done', 4: 'aborted', 5: 'cancelled', 130: 'interrupted', 2: 'failed to start'}


def project_commit() -> tuple[str, bool | None]:
    """The checkout's commit and whether it has uncommitted changes ('unknown', None outside
    a git checkout, e.g. a wheel install)."""
    root = config_dir().parent
    try:
        commit = subprocess.run(['git', '-C', str(root), 'rev-parse', 'HEAD'],
                                capture_output=True, text=True, check=True).stdout.strip()
        dirty = subprocess.run(['git', '-C', str(root), 'status', '--porcelain',
                                '--untracked-files=no'], capture_output=True, text=True,
                               check=True).stdout.strip() != ''
    except (OSError, subprocess.CalledProcessError):
        return 'unknown', None
    return commit, dirty


def _version(*names: str) -> str:
    for name in names:
        try:
            return importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            continue
    return 'unknown'


def run_description(scene: Scene, params: dict[str, Any], seed: int, layout: str,
                    argv: list[str] | None = None) -> dict[str, Any]:
    """Everything needed to know, later, how a bag was made and to make it again."""
    commit, dirty = project_commit()
    return {
        'scene': scene.name, 'scene_text': scene.source, 'seed': seed, 'layout': layout,
        'parameters': params, 'command_line': list(sys.argv if argv is None else argv),
        'commit': commit, 'dirty': dirty,
        'versions': {'pam_bench': _version('pam_bench', 'pam-bench'),
                     'rclpy': _version('ros-jazzy-rclpy', 'rclpy'),
                     'rosbags': _version('rosbags'), 'numpy': _version('numpy'),
                     'python': platform.python_version()},
        'host': socket.gethostname(), 'platform': platform.platform(),
        'start': datetime.datetime.now(datetime.UTC).isoformat(timespec='milliseconds')}


def end_state(code: int | None, reason: str = '') -> dict[str, Any]:
    """How a run ended from its exit code (None: interrupted before it had one)."""
    state = 'interrupted' if code is None else STATES.get(code, 'failed')
    return {'state': state, 'code': code, 'reason': reason,
            'end': datetime.datetime.now(datetime.UTC).isoformat(timespec='milliseconds')}


def write_end(path: str, code: int | None, reason: str = '') -> None:
    """Write ``end_state`` for the recorder to close the bag with (no-op without a path)."""
    if path:
        with open(path, 'w', encoding='utf-8') as fh:
            json.dump(end_state(code, reason), fh)
