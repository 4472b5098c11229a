"""A rosbag2 writer like rosbag2's own: zstd-compressed MCAP chunks, split by size and duration.

A bag folder holds its files ``NAME_0.mcap``, ``NAME_1.mcap``, ... (one, ``NAME.mcap``, when
it never split) and one ``metadata.yaml`` that lists every file with its start, duration and
message count, as rosbag2 writes it; any rosbag2 reader (rosbags, ``mcap`` + ``mcap_ros2``,
``@mcap/core``) opens it. Each file is a complete bag of rosbags' ``Writer`` while it is
written in ``NAME/.part_N/``; closed (the next one starts when the current file passes
``max_bytes`` or spans ``max_duration_ns`` of log time), it moves into the folder. Chunks are
compressed with zstd (rosbags' ``CompressionMode.STORAGE``) unless ``compress`` is off.

A disk that fills is met before it is full: every ``CHECK_EVERY`` writes the free space is
read, and below ``min_free_bytes`` ``write`` raises ``DiskFull`` without writing, so the bag
can still be closed valid with what it holds (its summary and metadata need a little room).

While it writes, the writer holds an exclusive ``flock`` on the bag folder (``bag_in_use``
tells): ``bag-repair`` refuses a bag that is still being written, and ``info`` and ``extract``
say so instead of calling it torn. The kernel drops the lock when the recorder dies.

A recorder killed with SIGKILL leaves the closed files whole and the last one torn in its part
folder, without metadata.yaml; ``bags.bag_repair`` rebuilds the torn file from its complete
chunks (at most ``flush``'s period is lost) and writes the metadata of all.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
import pathlib
import shutil
import struct
import zlib
from collections.abc import Callable
from typing import Any

import yaml

from pam_bench.bags.errors import DiskFull
from pam_bench.vocabulary.outputs import claim_output, seal_output

__all__ = ['SplitWriter', 'DiskFull', 'check_room', 'bag_in_use', 'lock_bag', 'part_name',
           'write_metadata', 'read_closed', 'PART_PREFIX', 'CLOSED']

PART_PREFIX = '.part_'
CLOSED = '.closed_parts.json'
"""While a bag is written: the metadata of its closed files (``bag_repair`` reads it)."""


_Loader = getattr(yaml, 'CSafeLoader', yaml.SafeLoader)
_Dumper = getattr(yaml, 'CSafeDumper', yaml.SafeDumper)


def free_bytes(path: pathlib.Path) -> int:
    """Bytes free for an ordinary user on the file system of ``path``."""
    st = os.statvfs(path)
    return int(st.f_bavail * st.f_frsize)


def check_room(path: pathlib.Path, min_free_bytes: int) -> None:
    """Check, before anything starts, that a bag can be written at ``path``: its nearest
    existing folder is writable, on a file system that stores files (not /proc or /sys) with
    at least ``min_free_bytes`` free.

    Raises:
        DiskFull: a pseudo-file system, or too little room.
        PermissionError: the folder is not writable.
    """
    here = pathlib.Path(path).expanduser().absolute()
    while not here.exists() and here != here.parent:
        here = here.parent
    if not here.is_dir():
        raise NotADirectoryError(errno.ENOTDIR, f'{here} is not a folder: a bag cannot be made '
                                 f'below it')
    try:
        st = os.statvfs(here)
    except OSError as exc:
        raise DiskFull(errno.ENOSPC, f'{path}: cannot read its file system: '
                       f'{exc.strerror}') from None
    if st.f_blocks == 0:
        raise DiskFull(errno.ENOSPC, f'{path}: {here} is on a file system that stores no files '
                       '(a pseudo-file system such as /proc or /sys)')
    if not os.access(here, os.W_OK | os.X_OK):
        raise PermissionError(errno.EACCES, f'{here} is not writable: a bag cannot be made in '
                              'it')
    free = int(st.f_bavail * st.f_frsize)
    if min_free_bytes and free < min_free_bytes:
        raise DiskFull(errno.ENOSPC, f'{free / 1e6:.0f} MB left on the disk of {path} (the '
                       f'recorder keeps {min_free_bytes / 1e6:.0f} MB free)')


def lock_bag(path: pathlib.Path) -> int | None:
    """An exclusive ``flock`` on the bag folder ``path`` (its descriptor; close it to let go),
    or None when another process holds it (a recorder writing the bag, a repair)."""
    fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError as exc:
        os.close(fd)
        if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
            return None
        raise
    return fd


def bag_in_use(path: pathlib.Path) -> bool:
    """Whether a live process (a recorder, a repair) holds the bag folder ``path``."""
    try:
        fd = lock_bag(path)
    except OSError:
        return False
    if fd is None:
        return True
    os.close(fd)
    return False


def _dump(path: pathlib.Path, data: Any) -> None:
    tmp = path.with_suffix('.tmp')
    tmp.write_text(json.dumps(data), encoding='utf-8')
    tmp.replace(path)


def read_closed(folder: pathlib.Path) -> tuple[list[dict[str, Any]], dict[str, str]]:
    """The closed parts' metadata and the custom data of a bag still being written (or
    killed while it was), from ``CLOSED``."""
    path = folder / CLOSED
    if not path.exists():
        return [], {}
    try:
        data = json.loads(path.read_text(encoding='utf-8'))
    except ValueError:        # killed while writing it: its .tmp is the torn one, this is whole
        data = {}
    return list(data.get('parts') or []), dict(data.get('custom') or {})


def part_name(folder: pathlib.Path, index: int, single: bool) -> str:
    """The file name of part ``index`` of the bag in ``folder``."""
    return f'{folder.name}.mcap' if single else f'{folder.name}_{index}.mcap'


def _meta_of(meta_path: pathlib.Path) -> dict[str, Any]:
    data = yaml.load(meta_path.read_text(encoding='utf-8'), Loader=_Loader)
    return dict(data['rosbag2_bagfile_information'])


def write_metadata(folder: pathlib.Path, parts: list[dict[str, Any]],
                   custom: dict[str, str]) -> None:
    """One metadata.yaml for the parts (each a part's own rosbag2 metadata, its file renamed
    as it lies in ``folder``): files, topics and counts summed, custom data over all."""
    first = parts[0]
    topics: dict[str, dict[str, Any]] = {}
    for p in parts:
        for t in p['topics_with_message_count']:
            name = t['topic_metadata']['name']
            if name in topics:
                topics[name]['message_count'] += t['message_count']
            else:
                topics[name] = {'topic_metadata': dict(t['topic_metadata']),
                                'message_count': t['message_count']}
    starts = [p['starting_time']['nanoseconds_since_epoch'] for p in parts if p['message_count']]
    ends = [p['starting_time']['nanoseconds_since_epoch'] + p['duration']['nanoseconds']
            for p in parts if p['message_count']]
    start = min(starts) if starts else 0
    files = [f for p in parts for f in p['files']]
    info = {'version': first['version'], 'storage_identifier': first['storage_identifier'],
            'relative_file_paths': [f['path'] for f in files],
            'duration': {'nanoseconds': (max(ends) - start) if ends else 0},
            'starting_time': {'nanoseconds_since_epoch': start},
            'message_count': sum(p['message_count'] for p in parts),
            'topics_with_message_count': list(topics.values()),
            'compression_format': first.get('compression_format', ''),
            'compression_mode': first.get('compression_mode', ''),
            'files': files, 'custom_data': custom or None,
            'ros_distro': first.get('ros_distro', 'rosbags')}
    tmp = folder / 'metadata.yaml.tmp'
    tmp.write_text(yaml.dump({'rosbag2_bagfile_information': info}, Dumper=_Dumper,
                             default_flow_style=False, sort_keys=False), encoding='utf-8')
    tmp.replace(folder / 'metadata.yaml')


_MESSAGE = struct.Struct('<BQHIQQ')
"""An MCAP Message record's head: opcode 0x05, record length, channel id, sequence, log time,
publish time (the data follows)."""
_CHUNK_BYTES = 2**20
"""rosbags' MCAP storage closes a chunk once its uncompressed bytes pass this."""

DirectWrite = Callable[[Any, int, bytes], None]
DirectWriteMany = Callable[[list[tuple[str, int, bytes]]], None]


def _put_records(writer: Any) -> Callable[[list[tuple[Any, int, bytes]]], None] | None:
    """A function that appends (connection, stamp, data) records, in order, to an open rosbags
    ``Writer`` with MCAP storage: the same bytes and counts as a ``Writer.write`` per message
    (seven small writes and checks each), with one ``struct`` call per record, one write per
    run of records between two chunk closes and the bookkeeping once per run. A chunk is closed
    after the record that takes it past rosbags' threshold, as ``Writer.write`` closes it.
    The records go into the chunk before any bookkeeping: a signal that interrupts a run (its
    handler raises between two Python statements) can leave records unindexed, never a torn
    record in the chunk the interrupted run closes. None when the writer is not the MCAP
    storage this was written against (its attributes are checked); ``test_splitwriter``
    holds the bytes equal to ``Writer.write``'s."""
    from rosbags.rosbag2 import CompressionMode
    storage: Any = getattr(writer, 'storage', None)
    needed = ('chunk', 'channel_stats', 'message_start_time', 'message_end_time',
              'close_chunk')
    if (type(storage).__name__ != 'McapWriter' or not all(hasattr(storage, a) for a in needed)
            or getattr(writer, 'compression_mode', None) == CompressionMode.MESSAGE
            or not isinstance(getattr(writer, 'counts', None), dict)
            or not all(hasattr(writer, a) for a in ('min_timestamp', 'max_timestamp'))):
        return None
    counts, stats, pack = writer.counts, storage.channel_stats, _MESSAGE.pack

    def put(items: list[tuple[Any, int, bytes]]) -> None:
        n = len(items)
        i = 0
        while i < n:
            chunk = storage.chunk
            bio = chunk.bio
            offset = bio.tell()
            records = []
            index = []
            lo = hi = items[i][1]
            while i < n:
                connection, ts, data = items[i]
                i += 1
                cid = connection.id
                record = pack(5, 22 + len(data), cid, 0, ts, ts) + data
                records.append(record)
                index.append((cid, ts, offset))
                offset += len(record)
                if ts < lo:
                    lo = ts
                elif ts > hi:
                    hi = ts
                if offset > _CHUNK_BYTES:
                    break
            bio.write(b''.join(records))
            msgs = chunk.msgs
            for cid, ts, at in index:
                msgs[cid].append((ts, at))
                stats[cid] += 1
                counts[cid] += 1
            if lo < storage.message_start_time:
                storage.message_start_time = lo
            if hi > storage.message_end_time:
                storage.message_end_time = hi
            if lo < writer.min_timestamp:
                writer.min_timestamp = lo
            if hi > writer.max_timestamp:
                writer.max_timestamp = hi
            if lo < chunk.message_start_time:
                chunk.message_start_time = lo
            if hi > chunk.message_end_time:
                chunk.message_end_time = hi
            if offset > _CHUNK_BYTES:
                storage.close_chunk()

    return put


_CRC_AT = 1 + 8 + 8 + 8 + 8
"""Offset of a Chunk record's uncompressed CRC from the record's start: opcode, record length,
message start and end time, uncompressed size."""


def with_chunk_crcs(writer: Any) -> bool:
    """Make the open rosbags ``Writer``'s MCAP storage write each chunk's uncompressed CRC
    (rosbags writes 0: no check). Its ``close_chunk`` is wrapped: the CRC-32 of the chunk's
    records, then the chunk written as rosbags writes it, then the 4 bytes put in place. A
    reader that validates CRCs (``mcap``'s, and ``bag-repair``) then finds a damaged chunk
    that still decompresses. False when the storage is not the one this was written against
    (the chunks stay without CRC); ``test_splitwriter`` names the internals it needs."""
    storage: Any = getattr(writer, 'storage', None)
    if type(storage).__name__ != 'McapWriter' or not all(
            hasattr(storage, a) for a in ('chunk', 'bio', 'close_chunk')):
        return False
    close = storage.close_chunk

    def close_chunk() -> None:
        crc = zlib.crc32(storage.chunk.bio.getbuffer())
        bio = storage.bio
        start = bio.tell()
        close()
        end = bio.tell()
        bio.seek(start + _CRC_AT)
        bio.write(_CRC.pack(crc))
        bio.seek(end)

    storage.close_chunk = close_chunk
    return True


_CRC = struct.Struct('<I')


def direct_write(writer: Any) -> DirectWrite | None:
    """A write of one message, ``write(connection, stamp, data)``, into an open rosbags
    ``Writer`` with MCAP storage, byte-equal to ``Writer.write`` (``_put_records``; a
    campaign writes a million messages and this takes about a third of the time). None when
    the writer is not that storage, so the caller keeps ``Writer.write``."""
    put = _put_records(writer)
    if put is None:
        return None

    def write(connection: Any, timestamp: int, data: bytes) -> None:
        put([(connection, timestamp, data)])

    return write


def direct_write_many(writer: Any, connections: dict[str, Any]) -> DirectWriteMany | None:
    """As ``direct_write``, for a list of (topic, stamp, data) written in that order, with
    ``connections`` (topic -> the writer's connection): the composed recorder writes an
    exchange's messages of every topic at once (``_put_records``)."""
    put = _put_records(writer)
    if put is None:
        return None

    def write_many(items: list[tuple[str, int, bytes]]) -> None:
        put([(connections[topic], ts, data) for topic, ts, data in items])

    return write_many


class SplitWriter:
    """A rosbag2 MCAP bag written in parts (module docstring).

    Args:
        path: the bag folder to create.
        compress: zstd-compress the MCAP chunks.
        max_bytes: start a new file past this size (0: never).
        max_duration_ns: start a new file once one spans this much log time (0: never).
        min_free_bytes: raise ``DiskFull`` rather than write when the disk has less free.
    """

    VERB = 'pam-bench record'
    """Who made the bag (its output marker, ``vocabulary.outputs``)."""
    CHECK_EVERY = 256
    """Writes between two checks of the file's size."""
    DIRECT = True
    """Write messages with ``direct_write`` where it applies (False: ``Writer.write``)."""

    def __init__(self, path: pathlib.Path, compress: bool = True, max_bytes: int = 0,
                 max_duration_ns: int = 0, min_free_bytes: int = 0) -> None:
        self.path = pathlib.Path(path)
        if self.path.exists():
            raise FileExistsError(f'bag directory {self.path} exists; remove it or pick another')
        self.compress = compress
        self.max_bytes = max_bytes
        self.max_duration_ns = max_duration_ns
        self.min_free_bytes = min_free_bytes
        self.custom: dict[str, str] = {}
        self.parts: list[dict[str, Any]] = []        # closed parts' metadata
        self._conns: dict[str, tuple[str, dict[str, Any]]] = {}   # topic -> (type, kwargs)
        self._current: dict[str, Any] = {}           # topic -> this part's connection
        self._writer: Any = None
        self._put: DirectWrite | None = None
        self._put_many: DirectWriteMany | None = None
        self._index = 0
        self._start_ns: int | None = None
        self._since_check = 0
        self._lock: int | None = None                # the folder's flock while writing

    # --- the rosbags Writer's surface the recorder uses ------------------------------------
    def open(self) -> None:
        """Create the folder and the first part.

        Raises:
            DiskFull: the disk has less than ``min_free_bytes`` free already.
        """
        check_room(self.path, self.min_free_bytes)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.path.mkdir()
        self._lock = lock_bag(self.path)
        claim_output(self.path, self.VERB, bag=True)
        self._open_part()
        _dump(self.path / CLOSED, {'parts': self.parts, 'custom': self.custom})

    def add_connection(self, topic: str, msgtype: str, **kwargs: Any) -> str:
        """Register ``topic`` (every part gets it); returns the key ``write`` takes."""
        self._conns[topic] = (msgtype, kwargs)
        self._current[topic] = self._writer.add_connection(topic, msgtype, **kwargs)
        return topic

    def set_custom_data(self, key: str, value: str) -> None:
        """Custom data of the bag (every part's metadata and the bag's)."""
        self.custom[key] = value
        if self._writer is not None:
            self._writer.set_custom_data(key, value)
            _dump(self.path / CLOSED, {'parts': self.parts, 'custom': self.custom})

    def write(self, topic: str, timestamp: int, data: bytes) -> None:
        """Write one message; start a new part first where the current one is full."""
        if self._start_ns is None:
            self._start_ns = timestamp
        elif self.max_duration_ns and timestamp - self._start_ns >= self.max_duration_ns:
            self._next_part()
            self._start_ns = timestamp
        self._since_check += 1
        if self._since_check >= self.CHECK_EVERY:
            self._since_check = 0
            if self.min_free_bytes:
                free = free_bytes(self.path)
                if free < self.min_free_bytes:
                    raise DiskFull(errno.ENOSPC, f'{free / 1e6:.0f} MB left on the disk of '
                                   f'{self.path} (the recorder keeps '
                                   f'{self.min_free_bytes / 1e6:.0f} MB free)')
            if self.max_bytes and self.size_of_current() >= self.max_bytes:
                self._next_part()
                self._start_ns = None
        put = self._put
        assert put is not None, 'write before open'
        put(self._current[topic], timestamp, data)

    def reserve_many(self, n: int) -> DirectWriteMany | None:
        """For ``n`` messages written next, in order, when ``write`` would do nothing between
        them but put them (no part to start, no disk or size check due): its bookkeeping for
        all ``n`` at once, and a function that puts a list of (topic, stamp, data)
        (``direct_write_many``); else None and the caller uses ``write`` (the recorder puts a
        whole exchange's messages this way)."""
        if (self.max_duration_ns or self._start_ns is None or self._put_many is None
                or self._since_check + n >= self.CHECK_EVERY):
            return None
        self._since_check += n
        return self._put_many

    def flush(self) -> None:
        """Write the pending chunk and flush the file (a SIGKILL loses at most what came
        since)."""
        storage = getattr(self._writer, 'storage', None)
        if storage is not None and hasattr(storage, 'close_chunk') and storage.chunk.bio.tell():
            storage.close_chunk()
            storage.bio.flush()

    def close(self) -> None:
        """Close the last part and write the bag's metadata.yaml."""
        if self._writer is None:
            return
        try:
            self._close_part(single=self._index == 0)
            write_metadata(self.path, self.parts, self.custom)
            (self.path / CLOSED).unlink(missing_ok=True)
            seal_output(self.path)
        finally:
            if self._lock is not None:
                with contextlib.suppress(OSError):
                    os.close(self._lock)
                self._lock = None

    # --- parts ---------------------------------------------------------------------------
    @property
    def files(self) -> list[str]:
        """The files closed so far."""
        return [f['path'] for p in self.parts for f in p['files']]

    def size_of_current(self) -> int:
        """Bytes of the current part: its file on disk and the chunk pending in memory
        (uncompressed, an upper bound of what it adds)."""
        storage = getattr(self._writer, 'storage', None)
        if storage is None:
            return 0
        return int(storage.bio.tell()) + int(storage.chunk.bio.tell())

    def _part_dir(self, index: int) -> pathlib.Path:
        return self.path / f'{PART_PREFIX}{index}'

    def _open_part(self) -> None:
        from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
        w = Writer(self._part_dir(self._index), version=9, storage_plugin=StoragePlugin.MCAP)
        if self.compress:
            w.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        w.open()
        with_chunk_crcs(w)
        for key, value in self.custom.items():
            w.set_custom_data(key, value)
        self._current = {t: w.add_connection(t, msgtype, **kw)
                         for t, (msgtype, kw) in self._conns.items()}
        self._writer = w
        self._put = (direct_write(w) if self.DIRECT else None) or w.write
        self._put_many = direct_write_many(w, self._current) if self.DIRECT else None

    def _close_part(self, single: bool) -> None:
        part = self._part_dir(self._index)
        self._writer.close()
        self._writer = None
        meta = _meta_of(part / 'metadata.yaml')
        name = part_name(self.path, self._index, single)
        src = part / f'{part.name}.mcap'
        src.replace(self.path / name)
        for f in meta['files']:
            f['path'] = name
        meta['relative_file_paths'] = [name]
        self.parts.append(meta)
        shutil.rmtree(part)
        _dump(self.path / CLOSED, {'parts': self.parts, 'custom': self.custom})

    def _next_part(self) -> None:
        self._close_part(single=False)
        self._index += 1
        self._open_part()
