"""The bag floor: a bag's messages encoded and written again as the composed recorder writes
them, without the bench (``benchmarks/limits.py`` times it beside the nodes).

Every message of the bag is read back and made into its rclpy message object (not timed); then,
timed, each is encoded as ``Recorder._write_exchange`` encodes an object from the intra-process
bus (``runtime.cdr``'s encoder of its class, else rclpy's serialisation) and written with the
recorder's writer (``bags.splitwriter.SplitWriter``, compressed), one ``reserve_many`` per
exchange: the messages from one ``/clock`` to the next.
"""

from __future__ import annotations

import pathlib
import time
from typing import Any

from rclpy.serialization import deserialize_message, serialize_message

from pam_bench.bags.splitwriter import SplitWriter
from pam_bench.bags.types import bench_typestore
from pam_bench.runtime import cdr
from pam_bench.runtime.messages import message_class

__all__ = ['write_again']


def write_again(bag: pathlib.Path, out: pathlib.Path) -> tuple[float, int]:
    """Encode and write every message of ``bag`` into the new folder ``out`` as the composed
    recorder does (module docstring).

    Returns:
        (wall seconds of the encoding and writing, messages written).

    Raises:
        FileExistsError: ``out`` exists (nothing is replaced).
    """
    from rosbags.highlevel import AnyReader
    if out.exists() or out.is_symlink():
        raise FileExistsError(f'{out}: exists; the bag floor writes a new folder')
    store = bench_typestore()
    with AnyReader([bag]) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        messages = [(c.topic, t, deserialize_message(bytes(raw), message_class(c.msgtype)))
                    for c, t, raw in reader.messages()]
    exchanges: list[list[tuple[str, int, Any]]] = [[]]
    for m in messages:
        if m[0] == '/clock' and exchanges[-1]:
            exchanges.append([])
        exchanges[-1].append(m)
    encoders = {t: cdr.encoder(message_class(mt)) or serialize_message for t, mt in types.items()}
    t0 = time.perf_counter()
    writer = SplitWriter(out, compress=True)
    writer.open()
    for topic, msgtype in types.items():
        writer.add_connection(topic, msgtype, typestore=store)
    for batch in exchanges:
        items = [(topic, t, encoders[topic](msg)) for topic, t, msg in batch]
        put_many = writer.reserve_many(len(items))
        if put_many is not None:
            put_many(items)
        else:
            for topic, t, data in items:
                writer.write(topic, t, data)
    writer.close()
    return time.perf_counter() - t0, len(messages)
