"""The rosbags typestore of the bench: ROS 2 Jazzy types plus msg_defs/ registered from text."""

from __future__ import annotations

import functools

from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from pam_bench.config.paths import msg_defs_dir

__all__ = ['msg_defs_dir', 'bench_typestore', 'PACKAGE']

PACKAGE = 'pam_bench_interfaces'


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
