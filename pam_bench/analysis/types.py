"""The rosbags typestore of the bench: ROS 2 Jazzy types plus msg_defs/ registered from text."""

from __future__ import annotations

import functools
import pathlib

from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

__all__ = ['msg_defs_dir', 'bench_typestore', 'PACKAGE']

PACKAGE = 'pam_bench_interfaces'


def msg_defs_dir() -> pathlib.Path:
    """Folder with the .msg files: the source tree's msg_defs/msg or the installed copy."""
    src = pathlib.Path(__file__).resolve().parents[2] / 'msg_defs' / 'msg'
    if src.is_dir():
        return src
    try:
        from ament_index_python.packages import get_package_share_directory
        return pathlib.Path(get_package_share_directory('pam_bench')) / 'msg_defs' / 'msg'
    except Exception as exc:  # noqa: BLE001
        raise FileNotFoundError('msg_defs/msg not found next to pam_bench nor installed') from exc


@functools.lru_cache(maxsize=1)
def bench_typestore() -> Typestore:
    """Jazzy typestore with every message of msg_defs/ registered."""
    store = get_typestore(Stores.ROS2_JAZZY)
    types = {}
    for path in sorted(msg_defs_dir().glob('*.msg')):
        types.update(get_types_from_msg(path.read_text(encoding='utf-8'),
                                        f'{PACKAGE}/msg/{path.stem}'))
    store.register(types)
    return store
