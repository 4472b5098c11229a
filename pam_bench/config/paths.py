"""Where the bench's data files are: the source tree, or the installed share directory.

A checkout has ``config/`` and ``msg_defs/`` beside the ``pam_bench`` package; ``pip install .``
and ``colcon build`` put copies in ``<prefix>/share/pam_bench/`` (setup.py ``data_files``).
Every reader of a config or interface file asks here, so the two layouts behave the same.
"""

from __future__ import annotations

import functools
import os
import pathlib
import sys

__all__ = ['share_dir', 'config_dir', 'scenes_dir', 'msg_defs_dir', 'PACKAGE']

PACKAGE = 'pam_bench'


def _candidates() -> list[pathlib.Path]:
    here = pathlib.Path(__file__).resolve().parents
    out = [here[2]]                     # a checkout: the repository root
    # an install (pip, colcon) puts the package at <prefix>/lib/pythonX.Y/site-packages and
    # the data at <prefix>/share/pam_bench: its own prefix first, then the interpreter's and
    # the ament prefixes
    if len(here) > 5:
        out.append(here[5] / 'share' / PACKAGE)
    prefixes = [sys.prefix]
    prefixes += [p for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if p]
    out += [pathlib.Path(p) / 'share' / PACKAGE for p in prefixes]
    return out


@functools.lru_cache(maxsize=1)
def share_dir() -> pathlib.Path:
    """The folder that holds ``config/`` and ``msg_defs/``.

    Raises:
        FileNotFoundError: neither a source tree nor an installed share directory has them.
    """
    for root in _candidates():
        if (root / 'config' / 'protocols.yaml').is_file() and (root / 'msg_defs').is_dir():
            return root
    raise FileNotFoundError('config/ and msg_defs/ of pam_bench not found beside the package '
                            f'nor in {sys.prefix}/share/{PACKAGE} (is pam_bench installed?)')


def config_dir() -> pathlib.Path:
    """``config/``: bench.yaml, protocols.yaml, inverse_model.yaml, scenes/."""
    return share_dir() / 'config'


def scenes_dir() -> pathlib.Path:
    """``config/scenes/``: one YAML file per scene."""
    return config_dir() / 'scenes'


def msg_defs_dir() -> pathlib.Path:
    """``msg_defs/msg``: the .msg files of pam_bench_interfaces."""
    return share_dir() / 'msg_defs' / 'msg'
