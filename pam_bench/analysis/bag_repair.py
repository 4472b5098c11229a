"""Repair a bag whose recorder was killed: keep every complete record, write a valid bag.

The recorder (``analysis.splitwriter``) writes MCAP chunks (schemas, channels, messages) into
the file it is filling, in ``NAME/.part_N/``, and flushes it every ``flush_period_s``; files
it closed lie beside it, listed in ``.closed_parts.json``. Only a close writes a file's
summary and footer, and the bag's metadata.yaml. After a SIGKILL the open file ends in the
middle of a chunk or after the last flushed one. ``repair_bag`` reads that file's records in
order until the first incomplete one, writes them into a new file (same topics, types, log
times and payloads) in the bag, and writes the metadata.yaml of every file; the torn file is
kept in ``NAME.broken/``. A bag of one file written by an older recorder (``NAME/NAME.mcap``
without metadata) is rebuilt the same way. What the recorder held in memory since its last
flush is lost: the report says how much of the file was unreadable and how many messages each
topic kept.
"""

from __future__ import annotations

import dataclasses
import pathlib
import shutil
from typing import Any

from pam_bench.analysis.errors import BagError
from pam_bench.analysis.splitwriter import (
    CLOSED,
    PART_PREFIX,
    part_name,
    read_closed,
    write_metadata,
)
from pam_bench.analysis.types import bench_typestore

__all__ = ['RepairReport', 'repair_bag']


@dataclasses.dataclass(frozen=True)
class RepairReport:
    """Outcome: whether a repair was needed, messages kept per topic (all files), bytes of the
    torn file that were unreadable, and where the torn file went."""

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


def _valid(path: pathlib.Path) -> dict[str, int] | None:
    """Messages per topic of a bag that opens, else None."""
    if not (path / 'metadata.yaml').exists():
        return None
    try:
        from rosbags.rosbag2 import Reader
        with Reader(path) as reader:
            counts: dict[str, int] = {}
            for c in reader.connections:
                counts[c.topic] = counts.get(c.topic, 0) + c.msgcount
            return counts
    except Exception:  # noqa: BLE001 - unreadable despite its metadata: repair it
        return None


def _rebuild(records: list, out: pathlib.Path, kept: dict[str, int]) -> dict[str, Any]:
    """Write ``records`` as a one-file bag in ``out``; count them in ``kept``; return the
    rosbag2 metadata of that file."""
    import yaml
    from mcap.records import Channel, Schema
    from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
    store = bench_typestore()
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    conns: dict[int, Any] = {}
    writer = Writer(out, version=9, storage_plugin=StoragePlugin.MCAP)
    writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
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
    meta = yaml.safe_load((out / 'metadata.yaml').read_text(encoding='utf-8'))
    return dict(meta['rosbag2_bagfile_information'])


def repair_bag(path: str | pathlib.Path) -> RepairReport:
    """Rebuild the torn file of ``path`` (a rosbag2 MCAP folder, split or not) from its
    readable records and write the bag's metadata.yaml.

    Raises:
        BagError: not a bag folder, or nothing readable in it.
    """
    from mcap.records import Message
    path = pathlib.Path(path)
    if not path.is_dir():
        raise BagError(f'{path}: no .mcap file to repair')
    counts = _valid(path)
    if counts is not None:
        return RepairReport(False, counts, 0, None)
    closed, custom = read_closed(path)
    closed_names = {f['path'] for p in closed for f in p['files']}
    torn = sorted(path.glob(f'{PART_PREFIX}*/*.mcap'),
                  key=lambda f: int(f.parent.name[len(PART_PREFIX):]))
    torn += [f for f in sorted(path.glob('*.mcap')) if f.name not in closed_names]
    if not torn and not closed:
        raise BagError(f'{path}: no .mcap file to repair')
    kept: dict[str, int] = {}
    for part in closed:
        for t in part['topics_with_message_count']:
            name = t['topic_metadata']['name']
            kept[name] = kept.get(name, 0) + t['message_count']
    broken = path.with_name(path.name + '.broken')
    shutil.rmtree(broken, ignore_errors=True)
    broken.mkdir()
    parts = list(closed)
    lost = 0
    for i, f in enumerate(torn):
        data = f.read_bytes()
        records, good = _records(data)
        lost += len(data) - good
        keep = broken / (f'{f.parent.name}.mcap' if f.parent != path else f.name)
        shutil.move(str(f), keep)
        if f.parent != path:
            shutil.rmtree(f.parent)
        if not any(isinstance(r, Message) for r in records):
            continue
        tmp = path / '.repairing'
        shutil.rmtree(tmp, ignore_errors=True)
        meta = _rebuild(records, tmp, kept)
        name = part_name(path, len(parts), single=not closed and len(torn) == 1 and i == 0)
        (tmp / f'{tmp.name}.mcap').replace(path / name)
        shutil.rmtree(tmp)
        for entry in meta['files']:
            entry['path'] = name
        meta['relative_file_paths'] = [name]
        parts.append(meta)
    if not any(p['message_count'] for p in parts):
        raise BagError(f'{path}: no complete message in {", ".join(f.name for f in torn)}')
    write_metadata(path, parts, custom)
    (path / CLOSED).unlink(missing_ok=True)
    return RepairReport(True, kept, lost, broken)
