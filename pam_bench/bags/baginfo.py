"""What a bag says about itself: how it was made and what it holds (``pam-bench info``).

The recorder stores the run's description in the bag's custom data (metadata.yaml, and the
same text in the MCAP file's rosbag2 metadata record): ``pam_bench.run`` (YAML: scene name
and file text, resolved parameters of every node, seed, command line, commit and dirty flag,
versions, host, start time) and ``pam_bench.end`` (YAML: how the run ended, the reason, end
time). ``bag_info`` reads both with the topic counts and durations.
"""

from __future__ import annotations

import pathlib
from typing import Any

from pam_bench.bags.bagread import open_bag
from pam_bench.bags.errors import BagError
from pam_bench.vocabulary.yaml_io import load_written

__all__ = ['RUN_KEY', 'END_KEY', 'bag_info', 'run_of_bag']

RUN_KEY = 'pam_bench.run'
END_KEY = 'pam_bench.end'


def _info(path: pathlib.Path) -> dict[str, Any]:
    """The rosbag2_bagfile_information of a bag's metadata.yaml."""
    meta = load_written((path / 'metadata.yaml').read_text(encoding='utf-8')) or {}
    return dict(meta.get('rosbag2_bagfile_information') or {})


def run_of_bag(path: str | pathlib.Path) -> dict[str, Any]:
    """The run description of a bag (``pam_bench.run``).

    Raises:
        BagError: not a bag, or a bag without a run description (made before it existed, or
            by another recorder).
    """
    path = pathlib.Path(path)
    open_bag(path).close()
    text = (_info(path).get('custom_data') or {}).get(RUN_KEY)
    if not text:
        raise BagError(f'{path}: no run description (recorded by an older pam_bench or '
                       'another recorder)')
    return dict(load_written(text))


def bag_info(path: str | pathlib.Path) -> dict[str, Any]:
    """Run description, end state and per-topic message counts and durations of a bag.

    Returns:
        ``bag``, ``run``, ``end``, ``duration_s``, ``start_s``, ``topics`` (name -> type,
        count), ``files`` ([(file name, bytes)]) and ``compression`` (of the chunks).

    Raises:
        BagError: not a readable bag.
    """
    path = pathlib.Path(path)
    reader = open_bag(path)
    try:
        topics = {}
        for c in reader.connections:
            topics[c.topic] = {'type': c.msgtype, 'count': c.msgcount}
        duration = reader.duration * 1e-9 if reader.message_count else 0.0
        start = reader.start_time * 1e-9 if reader.message_count else 0.0
    finally:
        reader.close()
    info = _info(path)
    names = info['relative_file_paths']
    files = [(n, (path / n).stat().st_size) for n in names if (path / n).exists()]
    custom = dict(info.get('custom_data') or {})
    run = load_written(custom[RUN_KEY]) if RUN_KEY in custom else None
    end = load_written(custom[END_KEY]) if END_KEY in custom else None
    return {'bag': str(path), 'run': run, 'end': end, 'duration_s': duration,
            'start_s': start, 'topics': topics, 'files': files,
            'compression': _compression(path / files[0][0]) if files else ''}


def _compression(mcap_file: pathlib.Path) -> str:
    """How the chunks of an MCAP file are compressed ('' for none; '?' when unknown)."""
    from mcap.reader import make_reader
    try:
        with open(mcap_file, 'rb') as fh:
            summary = make_reader(fh).get_summary()
    except Exception:  # noqa: BLE001 - another storage, or no summary: say so, not fail
        return '?'
    kinds = {c.compression for c in summary.chunk_indexes} if summary else set()
    return ', '.join(sorted(kinds))
