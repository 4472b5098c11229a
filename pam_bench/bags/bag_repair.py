"""Check a bag through, and repair one whose recorder was killed or whose chunks are damaged.

The recorder (``bags.splitwriter``) writes MCAP chunks (schemas, channels, messages) into
the file it is filling, in ``NAME/.part_N/``, and closes a chunk at least once a wall-clock
second; files it closed lie beside it, listed in ``.closed_parts.json``. Only a close writes a
file's summary and footer, and the bag's metadata.yaml. After a SIGKILL the open file ends in
the middle of a chunk or after the last closed one.

``repair_bag`` reads every MCAP file of the bag record by record, decompresses every chunk and
checks its CRC. A bag whose metadata opens and whose every chunk is whole is valid: nothing to
do. Otherwise every file that is torn (no footer), damaged (a chunk that does not decompress or
fails its CRC) or not listed is rebuilt from the records it can read, in order (same topics,
types, log times and payloads); files that are whole are kept as they are. The new
metadata.yaml lists every file, and keeps the run's description (``pam_bench.run``, ``.end``):
from ``.closed_parts.json``, the old metadata.yaml, or the MCAP files' own rosbag2 metadata
records. The old metadata.yaml stays beside it as ``metadata.yaml.before-repair``. The report
says what was kept per topic and what was dropped (chunks, bytes).

A repair is atomic: it builds the repaired bag in a stage folder beside the bag
(``.NAME.repair-PID``) and swaps the two folders in one step at the end, so the original bag,
whole, ends in ``NAME.broken/`` (a new folder, never one that was there). Interrupted or failed
at any moment (a signal, a full disk, a file-size limit) the bag is the original or the
repaired one, and the next repair finishes what the last left. It refuses a bag whose recorder
still writes it (the writer's lock, ``splitwriter.bag_in_use``), and what is not a ROS 2 bag
(an unknown rosbag2 version, a channel that is not CDR, a schema that is not a ROS 2 message
definition).
"""

from __future__ import annotations

import dataclasses
import io
import pathlib
import shutil
from typing import Any

from pam_bench.bags.errors import BagError
from pam_bench.bags.splitwriter import (
    CLOSED,
    PART_PREFIX,
    part_name,
    read_closed,
    write_metadata,
)
from pam_bench.bags.types import bench_typestore
from pam_bench.vocabulary.outputs import claim_output, seal_output
from pam_bench.vocabulary.yaml_io import load_written

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
    meta = load_written((out / 'metadata.yaml').read_text(encoding='utf-8'))
    return dict(meta['rosbag2_bagfile_information'])


def _old_info(path: pathlib.Path) -> dict[str, Any]:
    """The bag's metadata.yaml (its rosbag2_bagfile_information), {} when none is readable."""
    try:
        data = load_written((path / 'metadata.yaml').read_text(encoding='utf-8'))
        return dict((data or {}).get('rosbag2_bagfile_information') or {})
    except Exception:  # noqa: BLE001 - unreadable metadata: the repair rebuilds it
        return {}


def _custom_of(yaml_text: str) -> dict[str, str]:
    try:
        data: Any = load_written(yaml_text) or {}
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


STAGE_MARK = '.repair_stage'
"""In a repair's stage folder until the swap is done (``_recover`` tells stages from
originals by it)."""
SUPPORTED_VERSIONS = range(1, 10)
"""The rosbag2 metadata versions a repair knows (rosbags reads 1 to 9)."""
ROS2_ENCODINGS = ({'cdr'}, {'ros2msg', 'ros2idl'})
"""Message and schema encodings of a ROS 2 bag."""


def _stages(path: pathlib.Path) -> list[pathlib.Path]:
    """Stage folders of earlier repairs of ``path`` (``.NAME.repair-*`` beside it)."""
    return sorted(path.parent.glob(f'.{path.name}.repair-*'))


def _recover(path: pathlib.Path) -> None:
    """Finish what an interrupted repair of ``path`` left: after its swap, the originals still
    under the stage's name go to a ``.broken`` folder; before it, the stage is dropped (it
    holds links to the originals and rebuilt copies, nothing else)."""
    swapped = (path / STAGE_MARK).exists()
    for stage in _stages(path):
        if (stage / STAGE_MARK).exists() and not swapped:
            shutil.rmtree(stage, ignore_errors=True)
        elif not (stage / STAGE_MARK).exists():
            _keep_originals(stage, _fresh(path))
    (path / STAGE_MARK).unlink(missing_ok=True)


def _keep_originals(folder: pathlib.Path, broken: pathlib.Path) -> None:
    """Name the originals' folder ``broken`` and mark it as the repair's (so no verb's
    ``--overwrite`` takes it for a bag of its own)."""
    from pam_bench.vocabulary.outputs import MARKER
    folder.rename(broken)
    (broken / MARKER).unlink(missing_ok=True)
    seal_output(broken, _VERB)


def _exchange(a: pathlib.Path, b: pathlib.Path) -> None:
    """Swap the folders ``a`` and ``b`` in one step (Linux ``renameat2`` with
    ``RENAME_EXCHANGE``); where the system cannot, ``b`` moves to ``a``'s name after ``a``
    moved aside (a moment in which ``b``'s name is free)."""
    import ctypes
    import os
    libc = ctypes.CDLL(None, use_errno=True)
    fn = getattr(libc, 'renameat2', None)
    if fn is not None:
        at_fdcwd, rename_exchange = -100, 2
        if fn(at_fdcwd, os.fsencode(a), at_fdcwd, os.fsencode(b), rename_exchange) == 0:
            return
    aside = a.with_name(a.name + '.aside')
    b.rename(aside)
    a.rename(b)
    aside.rename(a)


def _check_ros2(path: pathlib.Path, info: dict[str, Any],
                scans: dict[pathlib.Path, FileScan]) -> None:
    """Refuse what is not a ROS 2 bag: an unknown metadata version, a channel that is not CDR
    or a schema that is not a ROS 2 message definition.

    Raises:
        BagError: one line naming what is foreign.
    """
    from mcap.records import Channel, Schema
    version = info.get('version')
    if info and (not isinstance(version, int) or version not in SUPPORTED_VERSIONS):
        raise BagError(f'{path}: metadata.yaml says rosbag2 version {version!r}; bag-repair '
                       f'knows versions {SUPPORTED_VERSIONS.start} to '
                       f'{SUPPORTED_VERSIONS.stop - 1}: not repaired')
    for f, scan in scans.items():
        for r in scan.records:
            if isinstance(r, Channel) and r.message_encoding not in ROS2_ENCODINGS[0]:
                raise BagError(f'{path}: not a ROS 2 bag: {f.name} holds {r.topic} encoded as '
                               f'{r.message_encoding!r}, not CDR; bag-repair repairs rosbag2 '
                               'MCAP bags')
            if isinstance(r, Schema) and r.encoding not in ROS2_ENCODINGS[1]:
                raise BagError(f'{path}: not a ROS 2 bag: {f.name} holds the schema {r.name!r} '
                               f'as {r.encoding!r}, not a ROS 2 message definition; '
                               'bag-repair repairs rosbag2 MCAP bags')


def repair_bag(path: str | pathlib.Path) -> RepairReport:
    """Check the bag ``path`` through and rebuild what is torn or damaged (module docstring).

    The repaired bag is built in a stage folder beside the bag (whole files linked, torn ones
    rebuilt, the new metadata), then swapped with the bag in one step; the originals, whole,
    end in a new ``.broken`` folder. Interrupted or failed at any moment, the bag is the
    original or the repaired one, and the next repair finishes the job. A bag whose recorder
    still writes it is refused.

    Raises:
        BagError: not a bag folder, being written, not a ROS 2 bag, or nothing readable in it.
    """
    from pam_bench.bags.splitwriter import lock_bag
    given = pathlib.Path(path)
    path = given.resolve()
    if not path.is_dir():
        raise BagError(f'{given}: no such bag folder')
    lock = lock_bag(path)
    if lock is None:
        raise BagError(f'{given}: being written (its recorder is running) or repaired by '
                       'another bag-repair: repair it once that has ended')
    try:
        _recover(path)
        return _repair(path, given)
    finally:
        import os
        os.close(lock)


def _repair(path: pathlib.Path, given: pathlib.Path) -> RepairReport:
    """``repair_bag`` on a bag this process holds."""
    import os
    info = _old_info(path)
    listed = [str(n) for n in info.get('relative_file_paths') or []]
    closed, custom = read_closed(path)
    closed_names = {f['path'] for p in closed for f in p['files']}
    parts = sorted(path.glob(f'{PART_PREFIX}*/*.mcap'),
                   key=lambda f: int(f.parent.name[len(PART_PREFIX):]) if
                   f.parent.name[len(PART_PREFIX):].isdigit() else 0)
    files = sorted(path.glob('*.mcap'))
    if not files and not parts:
        raise BagError(f'{given}: no .mcap file to repair')
    scans = {f: scan_file(f) for f in [*files, *parts]}
    _check_ros2(given, info, scans)
    meta_ok = bool(info) and set(listed) == {f.name for f in files} and not parts
    if meta_ok and all(s.whole for s in scans.values()):
        return RepairReport(False, _counts(scans), 0, None)
    for s in scans.values():
        custom = {**_custom_of(s.metadata_yaml), **custom}
    custom = {**(info.get('custom_data') or {}), **custom}
    order = [f for f in files if f.name in closed_names or f.name in listed]
    order += [f for f in files if f not in order] + parts
    from mcap.records import Message
    if not any(isinstance(r, Message) for f in order for r in scans[f].records):
        raise BagError(f'{given}: no complete message in {", ".join(f.name for f in order)}: '
                       'nothing to rebuild, nothing changed')
    stage = path.with_name(f'.{path.name}.repair-{os.getpid()}')
    shutil.rmtree(stage, ignore_errors=True)
    stage.mkdir()
    try:
        claim_output(stage, _bag_verb(path), bag=True)
        (stage / STAGE_MARK).write_text(str(path), encoding='utf-8')
        report = _build(path, stage, order, scans, closed, closed_names, listed, info, custom)
        _exchange(stage, path)            # the bag is the repaired one from here on
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    (path / STAGE_MARK).unlink(missing_ok=True)
    broken = _fresh(path)
    _keep_originals(stage, broken)
    return dataclasses.replace(report, broken_copy=broken)


def _build(path: pathlib.Path, stage: pathlib.Path, order: list[pathlib.Path],
           scans: dict[pathlib.Path, FileScan], closed: list[dict[str, Any]],
           closed_names: set[str], listed: list[str], info: dict[str, Any],
           custom: dict[str, str]) -> RepairReport:
    """The repaired bag of ``path`` in ``stage``: whole files linked, the others rebuilt, the
    other files of the folder (statistics) linked, the new metadata and the old beside it."""
    from pam_bench.vocabulary.outputs import MARKER
    kept: dict[str, int] = {}
    new_parts: list[dict[str, Any]] = []
    lost = bad = 0
    rebuilt: list[str] = []
    single = len(order) == 1
    for f in order:
        scan = scans[f]
        if f.parent == path and scan.whole and (f.name in closed_names or f.name in listed):
            part = next((p for p in closed if any(x['path'] == f.name for x in p['files'])),
                        None) or _intact_part(f.name, scan, info)
            _link(f, stage / f.name)
            new_parts.append(part)
            for t in part['topics_with_message_count']:
                name = t['topic_metadata']['name']
                kept[name] = kept.get(name, 0) + t['message_count']
            continue
        lost += scan.size - scan.good_bytes
        bad += scan.bad_chunks
        rebuilt.append(f.name)
        from mcap.records import Message
        if not any(isinstance(r, Message) for r in scan.records):
            continue
        tmp = stage / '.rebuilding'
        meta = _rebuild(scan.records, tmp, kept)
        name = part_name(path, len(new_parts), single=single)
        (tmp / f'{tmp.name}.mcap').replace(stage / name)
        shutil.rmtree(tmp)
        for entry in meta['files']:
            entry['path'] = name
        meta['relative_file_paths'] = [name]
        new_parts.append(meta)
    skip = {MARKER, CLOSED, 'metadata.yaml', OLD_METADATA, *(f.name for f in order)}
    for f in path.iterdir():             # what else the run kept there (wall_stats.json)
        if f.is_file() and f.name not in skip and not f.name.startswith(PART_PREFIX):
            _link(f, stage / f.name)
    if (path / 'metadata.yaml').exists():
        shutil.copyfile(path / 'metadata.yaml', stage / OLD_METADATA)
    write_metadata(stage, new_parts, custom)
    (stage / STAGE_MARK).unlink()         # the marker lists the bag's files, not this one
    seal_output(stage)
    (stage / STAGE_MARK).write_text(str(path), encoding='utf-8')
    return RepairReport(True, kept, lost, None, bad, tuple(rebuilt))


def _bag_verb(path: pathlib.Path) -> str:
    """Who the repaired bag belongs to: the verb that recorded it (so that its ``run
    --overwrite`` may replace it), else the repair."""
    from pam_bench.vocabulary.outputs import BAG_VERBS, own_files
    own = own_files(path)
    return own[0] if own is not None and own[0] in BAG_VERBS else _VERB


def _link(src: pathlib.Path, dst: pathlib.Path) -> None:
    """``dst`` as a hard link to ``src`` (a copy where the file system has none)."""
    import os
    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)


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
