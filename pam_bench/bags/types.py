"""The rosbags typestores of the bench: ROS 2 Jazzy types plus msg_defs/ registered from text
(``bench_typestore``), and the few types a run records, read from their .msg files
(``typestore_of``)."""

from __future__ import annotations

import functools
import importlib.util
import os
import pathlib
import sys
from collections.abc import Iterator

from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.base import Nodetype
from rosbags.typesys.store import Typestore

from pam_bench.config.paths import msg_defs_dir

__all__ = ['msg_defs_dir', 'bench_typestore', 'typestore_of', 'PACKAGE']

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


def _prefix_of(package: str) -> list[str]:
    """The install prefix of the Python package ``package`` that this process imports
    (``PREFIX/lib/pythonX.Y/site-packages/package``), as a list of none or one."""
    try:
        spec = importlib.util.find_spec(package)
    except (ImportError, ValueError):
        return []
    if spec is None or not spec.origin:
        return []
    parents = pathlib.Path(spec.origin).parents
    return [str(parents[4])] if len(parents) > 4 else []


def _msg_file(msgtype: str) -> pathlib.Path | None:
    """The .msg file of ``msgtype`` ('pkg/msg/Name'): msg_defs/ for the bench's own, else the
    share folder of its package under a ROS prefix: first the one of the Python package this
    process imports (whose messages it publishes), then ``AMENT_PREFIX_PATH``'s, then the
    Python environment's (where the ROS wheels put it); None when there is none."""
    pkg, kind, name = (msgtype.split('/') + ['', ''])[:3]
    if kind != 'msg' or not name:
        return None
    if pkg == PACKAGE:
        path = msg_defs_dir() / f'{name}.msg'
        return path if path.is_file() else None
    prefixes = [p for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if p]
    for prefix in [*_prefix_of(pkg), *prefixes, sys.prefix]:
        path = pathlib.Path(prefix) / 'share' / pkg / 'msg' / f'{name}.msg'
        if path.is_file():
            return path
    return None


def _names(desc: tuple) -> Iterator[str]:
    """The message types a field of a parsed definition holds (rosbags' field descriptor)."""
    nodetype, detail = desc
    if nodetype == Nodetype.NAME:
        yield detail
    elif nodetype in (Nodetype.ARRAY, Nodetype.SEQUENCE):
        yield from _names(detail[0])


@functools.lru_cache(maxsize=8)
def typestore_of(msgtypes: tuple[str, ...]) -> Typestore:
    """A typestore of ``msgtypes`` and the types they hold, each parsed from its .msg file
    (``_msg_file``); ``bench_typestore`` when one of them has none.

    What a lock-step run's recorder needs: a handful of types whose definitions give the same
    message definition and type hash in the bag as ``bench_typestore``'s (``test_types``),
    without importing rosbags' whole Jazzy store, which took about 60 ms of every run's start
    (docs/long_runs.md, "The recorder's typestore").
    """
    types: dict[str, tuple] = {}
    todo = list(msgtypes)
    while todo:
        name = todo.pop()
        if name in types:
            continue
        path = _msg_file(name)
        if path is None:
            return bench_typestore()
        parsed = get_types_from_msg(path.read_text(encoding='utf-8'), name)
        types.update(parsed)
        todo += [n for _, fields in parsed.values() for _, desc in fields
                 for n in _names(desc)]
    store = get_typestore(Stores.EMPTY)
    store.register(types)
    return store
