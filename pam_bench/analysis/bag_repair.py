"""Check a bag through, and repair one whose recorder was killed or whose chunks are damaged.

The recorder (``analysis.splitwriter``) writes MCAP chunks (schemas, channels, messages) into
the file it is filling, in ``NAME/.part_N/``, and closes a chunk at least once a wall-clock
second; files it closed lie beside it, listed in ``.closed_parts.json``. Only a close writes a
file's summary and footer, and the bag's metadata.yaml. After a SIGKILL the open file ends in
the middle of a chunk or after the last closed one.

``repair_bag`` reads every MCAP file of the bag record by record, decompresses every chunk and
checks its CRC. A bag whose metadata opens and whose every chunk is whole is valid: nothing to
do. Otherwise every file that is torn (no footer), damaged (a chunk that does not decompress or
fails its CRC) or not listed is rebuilt from the records it can read, in order (same topics,
types, log times and payloads), its original moved to ``NAME.broken/`` (a new folder
beside the bag, never one that was there); files that are whole stay as they are. The new
metadata.yaml lists every file, and keeps the run's description (``pam_bench.run``, ``.end``):
from ``.closed_parts.json``, the old metadata.yaml, or the MCAP files' own rosbag2 metadata
records. The old metadata.yaml stays beside it as ``metadata.yaml.before-repair``. The report
says what was kept per topic and what was dropped (chunks, bytes).
"""

from __future__ import annotations

import dataclasses
import io
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
from pam_bench.vocabulary.outputs import claim_output, note_output_file, seal_output

__all__ = ['RepairReport', 'FileScan', 'scan_file', 'repair_bag', 'OLD_METADATA']

OLD_METADATA = 'metadata.yaml.before-repair'
"""The metadata.yaml a repair replaced, kept beside the new one."""
_VERB = 'pam-bench bag-repair'


@dataclasses.dataclass(frozen=True)
class RepairReport:
    """Outcome: whether a repair was needed, messages kept per topic (all files), bytes that
    could not be read, chunks dropped as damaged, where the originals went, and the files
    rebuilt."""

    needed: bool
    kept: dict[str, int]
    lost_bytes: int
    broken_copy: pathlib.Path | None
    bad_chunks: int = 0
    rebuilt: tuple[str, ...] = ()


@dataclasses.dataclass
class FileScan:
    """One MCAP file read through: its schemas, channels and messages in order, where reading
    stopped, whether it reached the footer, the chunks that did not decompress or failed their
    CRC, and its rosbag2 metadata record (YAML text, '' when absent)."""

    records: list[Any]
    good_bytes: int
    size: int
    complete: bool
    bad_chunks: int
    metadata_yaml: str

    @property
    def whole(self) -> bool:
        """Nothing lost: the footer reached, every chunk whole."""
        return self.complete and not self.bad_chunks


def scan_file(path: pathlib.Path) -> FileScan:
    """Read an MCAP file through (module docstring). A whole file's summary is checked too:
    every chunk its index lists was read, with the same times and sizes, and as many messages
    as its statistics count (a damaged chunk header, an opcode the reader skips)."""
    from mcap.records import (
        Channel,
        Chunk,
        ChunkIndex,
        Footer,
        Message,
        Metadata,
        Schema,
        Statistics,
    )
    from mcap.stream_reader import StreamReader, breakup_chunk
    data = path.read_bytes()
    stream = io.BytesIO(data)
    out: list[Any] = []
    good, bad, complete, meta = 0, 0, False, ''
    chunks: dict[int, tuple[int, int, int]] = {}      # offset -> (start, end, size)
    indexed: dict[int, tuple[int, int, int]] = {}
    expected: int | None = None
    messages = 0
    try:
        for rec in StreamReader(stream, emit_chunks=True).records:
            if isinstance(rec, Chunk):
                chunks[good] = (rec.message_start_time, rec.message_end_time,
                                rec.uncompressed_size)
                try:
                    inner = [r for r in breakup_chunk(rec, validate_crc=True)
                             if isinstance(r, (Schema, Channel, Message))]
                except Exception:  # noqa: BLE001 - a damaged chunk: counted and dropped
                    bad += 1
                else:
                    out.extend(inner)
                    messages += sum(isinstance(r, Message) for r in inner)
            elif isinstance(rec, (Schema, Channel, Message)):
                out.append(rec)
                messages += isinstance(rec, Message)
            elif isinstance(rec, Metadata) and rec.name == 'rosbag2':
                meta = rec.metadata.get('serialized_metadata', '')
            elif isinstance(rec, ChunkIndex):
                indexed[rec.chunk_start_offset] = (rec.message_start_time, rec.message_end_time,
                                                   rec.uncompressed_size)
            elif isinstance(rec, Statistics):
                expected = rec.message_count
            elif isinstance(rec, Footer):
                complete = True
            good = stream.tell()
    except Exception:  # noqa: BLE001 - a torn record ends the readable part, whatever raised
        pass
    if complete and not bad and ((indexed and indexed != chunks)
                                 or (expected is not None and expected != messages)):
        bad = max(1, len(set(indexed.items()) ^ set(chunks.items())))
    return FileScan(out, good, len(data), complete, bad, meta)


def _rebuild(records: list[Any], out: pathlib.Path, kept: dict[str, int]) -> dict[str, Any]:
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
    for rec in records:          # a whole file's summary repeats them: a damaged chunk's too
        if isinstance(rec, Schema):
            schemas.setdefault(rec.id, rec)
        elif isinstance(rec, Channel):
            channels.setdefault(rec.id, rec)
    try:
        for rec in records:
            if isinstance(rec, (Schema, Channel)):
                continue
            if rec.channel_id in channels and channels[rec.channel_id].schema_id in schemas:
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


def _old_info(path: pathlib.Path) -> dict[str, Any]:
    """The bag's metadata.yaml (its rosbag2_bagfile_information), {} when none is readable."""
    import yaml
    try:
        data = yaml.safe_load((path / 'metadata.yaml').read_text(encoding='utf-8'))
        return dict((data or {}).get('rosbag2_bagfile_information') or {})
    except Exception:  # noqa: BLE001 - unreadable metadata: the repair rebuilds it
        return {}


def _custom_of(yaml_text: str) -> dict[str, str]:
    import yaml
    try:
        data: Any = yaml.safe_load(yaml_text) or {}
        info: Any = data.get('rosbag2_bagfile_information', data)
        return {str(k): str(v) for k, v in (info.get('custom_data') or {}).items()}
    except Exception:  # noqa: BLE001 - a damaged record: nothing from it
        return {}


def _intact_part(name: str, scan: FileScan, info: dict[str, Any]) -> dict[str, Any]:
    """The rosbag2 metadata of a whole file kept as it is: its entry of the old metadata and
    its messages per topic counted from the scan."""
    from mcap.records import Channel, Message
    topics = {t['topic_metadata']['name']: t['topic_metadata']
              for t in info.get('topics_with_message_count') or []}
    channels = {r.id: r.topic for r in scan.records if isinstance(r, Channel)}
    counts: dict[str, int] = {}
    times = [r.log_time for r in scan.records if isinstance(r, Message)]
    for r in scan.records:
        if isinstance(r, Message) and r.channel_id in channels:
            counts[channels[r.channel_id]] = counts.get(channels[r.channel_id], 0) + 1
    start = min(times, default=0)
    entry = next((f for f in info.get('files') or [] if f.get('path') == name),
                 {'path': name, 'starting_time': {'nanoseconds_since_epoch': start},
                  'duration': {'nanoseconds': max(times, default=0) - start},
                  'message_count': len(times)})
    return {'version': info.get('version', 9), 'storage_identifier': 'mcap',
            'files': [entry], 'relative_file_paths': [name],
            'starting_time': {'nanoseconds_since_epoch': start},
            'duration': {'nanoseconds': max(times, default=0) - start},
            'message_count': len(times),
            'topics_with_message_count': [
                {'topic_metadata': topics.get(t, {'name': t}), 'message_count': n}
                for t, n in counts.items()],
            'compression_format': info.get('compression_format', ''),
            'compression_mode': info.get('compression_mode', ''),
            'ros_distro': info.get('ros_distro', 'rosbags')}


def _fresh(path: pathlib.Path) -> pathlib.Path:
    """A folder beside ``path`` that does not exist yet, for the originals."""
    for i in range(1, 10_000):
        cand = path.with_name(path.name + ('.broken' if i == 1 else f'.broken-{i}'))
        if not cand.exists():
            return cand
    raise BagError(f'{path}: no free name for its .broken folder')


def repair_bag(path: str | pathlib.Path) -> RepairReport:
    """Check the bag ``path`` through and rebuild what is torn or damaged (module docstring).

    Raises:
        BagError: not a bag folder, or nothing readable in it.
    """
    path = pathlib.Path(path)
    if not path.is_dir():
        raise BagError(f'{path}: no such bag folder')
    info = _old_info(path)
    listed = [str(n) for n in info.get('relative_file_paths') or []]
    closed, custom = read_closed(path)
    closed_names = {f['path'] for p in closed for f in p['files']}
    parts = sorted(path.glob(f'{PART_PREFIX}*/*.mcap'),
                   key=lambda f: int(f.parent.name[len(PART_PREFIX):]) if
                   f.parent.name[len(PART_PREFIX):].isdigit() else 0)
    files = sorted(path.glob('*.mcap'))
    if not files and not parts:
        raise BagError(f'{path}: no .mcap file to repair')
    scans = {f: scan_file(f) for f in [*files, *parts]}
    meta_ok = bool(info) and set(listed) == {f.name for f in files} and not parts
    if meta_ok and all(s.whole for s in scans.values()):
        return RepairReport(False, _counts(scans), 0, None)
    for s in scans.values():
        custom = {**_custom_of(s.metadata_yaml), **custom}
    custom = {**(info.get('custom_data') or {}), **custom}
    kept: dict[str, int] = {}
    new_parts: list[dict[str, Any]] = []
    broken: pathlib.Path | None = None
    lost = bad = 0
    rebuilt: list[str] = []
    order = [f for f in files if f.name in closed_names or f.name in listed]
    order += [f for f in files if f not in order] + parts
    single = len(order) == 1
    for f in order:
        scan = scans[f]
        if f.parent == path and scan.whole and (f.name in closed_names or f.name in listed):
            part = next((p for p in closed if any(x['path'] == f.name for x in p['files'])),
                        None) or _intact_part(f.name, scan, info)
            new_parts.append(part)
            for t in part['topics_with_message_count']:
                name = t['topic_metadata']['name']
                kept[name] = kept.get(name, 0) + t['message_count']
            continue
        lost += scan.size - scan.good_bytes
        bad += scan.bad_chunks
        if broken is None:
            broken = _fresh(path)
            claim_output(broken, _VERB)
        keep = broken / (f'{f.parent.name}.mcap' if f.parent != path else f.name)
        shutil.move(str(f), keep)
        if f.parent != path:
            shutil.rmtree(f.parent)
        rebuilt.append(f.name)
        from mcap.records import Message
        if not any(isinstance(r, Message) for r in scan.records):
            continue
        tmp = path / '.repairing'
        shutil.rmtree(tmp, ignore_errors=True)
        meta = _rebuild(scan.records, tmp, kept)
        name = part_name(path, len(new_parts), single=single)
        (tmp / f'{tmp.name}.mcap').replace(path / name)
        shutil.rmtree(tmp)
        for entry in meta['files']:
            entry['path'] = name
        meta['relative_file_paths'] = [name]
        new_parts.append(meta)
    if broken is not None:
        seal_output(broken)
    if not any(p['message_count'] for p in new_parts):
        raise BagError(f'{path}: no complete message in {", ".join(f.name for f in order)}')
    if (path / 'metadata.yaml').exists():
        (path / 'metadata.yaml').replace(path / OLD_METADATA)
    write_metadata(path, new_parts, custom)
    (path / CLOSED).unlink(missing_ok=True)
    for name in ('metadata.yaml', OLD_METADATA, *(p['files'][0]['path'] for p in new_parts)):
        note_output_file(path, name)
    return RepairReport(True, kept, lost, broken, bad, tuple(rebuilt))


def _counts(scans: dict[pathlib.Path, FileScan]) -> dict[str, int]:
    """Messages per topic of the scanned files."""
    from mcap.records import Channel, Message
    out: dict[str, int] = {}
    for s in scans.values():
        channels = {r.id: r.topic for r in s.records if isinstance(r, Channel)}
        for r in s.records:
            if isinstance(r, Message) and r.channel_id in channels:
                out[channels[r.channel_id]] = out.get(channels[r.channel_id], 0) + 1
    return out
