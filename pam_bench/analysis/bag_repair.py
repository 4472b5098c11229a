"""Repair a bag whose recorder was killed: keep every complete record, write a valid bag.

The recorder writes MCAP chunks (schemas, channels, messages) and flushes the file every
``flush_period_s``; only its close writes the summary, the footer and metadata.yaml. After a
SIGKILL the file ends in the middle of a chunk or after the last flushed one. ``repair_bag``
reads the records in order until the first incomplete one, writes them into a new bag (same
topics, types, log times and payloads) and puts it in place of the old one, which is kept as
``NAME.broken``. What the recorder held in memory since its last flush is lost: the report
says how much of the file was unreadable and how many messages each topic kept.
"""

from __future__ import annotations

import dataclasses
import pathlib
import shutil
from typing import Any

from pam_bench.analysis.errors import BagError
from pam_bench.analysis.types import bench_typestore

__all__ = ['RepairReport', 'repair_bag']


@dataclasses.dataclass(frozen=True)
class RepairReport:
    """Outcome: whether a repair was needed, messages kept per topic, bytes of the old file
    that were unreadable (a torn chunk), and where the old file went."""

    needed: bool
    kept: dict[str, int]
    lost_bytes: int
    broken_copy: pathlib.Path | None


def _records(data: bytes) -> tuple[list, int]:
    """Schemas, channels and messages in file order, and the offset where reading stopped."""
    import io

    from mcap.records import Channel, Chunk, Message, Schema
    from mcap.stream_reader import StreamReader, breakup_chunk
    stream = io.BytesIO(data)
    out: list = []
    good = 0
    try:
        for rec in StreamReader(stream, emit_chunks=True).records:
            if isinstance(rec, Chunk):
                out.extend(r for r in breakup_chunk(rec)
                           if isinstance(r, (Schema, Channel, Message)))
            elif isinstance(rec, (Schema, Channel, Message)):
                out.append(rec)
            good = stream.tell()
    except Exception:  # noqa: BLE001 - a torn record ends the readable part, whatever raised
        pass
    return out, good


def repair_bag(path: str | pathlib.Path) -> RepairReport:
    """Rebuild ``path`` (a rosbag2 MCAP folder) from its readable records.

    Raises:
        BagError: not a bag folder, or nothing readable in it.
    """
    from mcap.records import Channel, Message, Schema
    from rosbags.rosbag2 import StoragePlugin, Writer
    path = pathlib.Path(path)
    files = sorted(path.glob('*.mcap')) if path.is_dir() else []
    if not files:
        raise BagError(f'{path}: no .mcap file to repair')
    if (path / 'metadata.yaml').exists():
        try:
            from rosbags.rosbag2 import Reader
            with Reader(path) as reader:
                counts = {c.topic: c.msgcount for c in reader.connections}
            return RepairReport(False, counts, 0, None)
        except Exception:  # noqa: BLE001 - unreadable despite its metadata: repair it
            pass
    data = files[0].read_bytes()
    records, good = _records(data)
    if not any(isinstance(r, Message) for r in records):
        raise BagError(f'{path}: no complete message in {files[0].name}')
    store = bench_typestore()
    broken = path.with_name(path.name + '.broken')
    tmp = path.with_name(path.name + '.repairing')
    shutil.rmtree(tmp, ignore_errors=True)
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    conns: dict[int, Any] = {}
    kept: dict[str, int] = {}
    writer = Writer(tmp, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.open()
    try:
        for rec in records:
            if isinstance(rec, Schema):
                schemas[rec.id] = rec
            elif isinstance(rec, Channel):
                channels[rec.id] = rec
            elif rec.channel_id in channels:
                ch = channels[rec.channel_id]
                if rec.channel_id not in conns:
                    schema = schemas[ch.schema_id]
                    msgtype = schema.name
                    try:
                        rihs01 = store.hash_rihs01(msgtype)
                    except Exception:  # noqa: BLE001 - a type the bench does not know
                        rihs01 = 'RIHS01_' + '0' * 64
                    conns[rec.channel_id] = writer.add_connection(
                        ch.topic, msgtype, msgdef=schema.data.decode(), rihs01=rihs01)
                writer.write(conns[rec.channel_id], rec.log_time, rec.data)
                kept[ch.topic] = kept.get(ch.topic, 0) + 1
    finally:
        writer.close()
    shutil.rmtree(broken, ignore_errors=True)
    path.rename(broken)
    tmp.rename(path)
    (path / f'{tmp.name}.mcap').rename(path / f'{path.name}.mcap')
    _fix_metadata(path, tmp.name)
    return RepairReport(True, kept, len(data) - good, broken)


def _fix_metadata(path: pathlib.Path, old_stem: str) -> None:
    """metadata.yaml names the .mcap file written under the temporary name."""
    meta = path / 'metadata.yaml'
    meta.write_text(meta.read_text().replace(f'{old_stem}.mcap', f'{path.name}.mcap'))
