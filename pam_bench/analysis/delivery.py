"""What a recorder got against what was published: a count per topic, no guessing.

Each node on a wall clock counts the messages it puts on DDS per topic (``published``); the
recorder counts what it wrote and keeps, per publisher, the first and last publication
sequence number it received with how many it received (a topic of the contract has one
publisher; ``/diagnostics`` has one per node, told apart by the node its statuses name). A
DDS writer numbers its messages 1, 2, ..., so per publisher:

* ``before``: messages published before the recorder matched (sequence numbers below the
  first it saw): not recorded, not lost;
* ``gaps``: messages missing between the first and the last it saw: lost;
* ``tail``: messages published after the last it saw (``published - last``): lost, as the
  recorder is stopped last.

A topic's figures sum its publishers'; where a publisher's count or sequence is not known
(a node that kept no statistics, a lab's driver), they are unknown (``None``), never guessed.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

__all__ = ['Delivery', 'delivery_table', 'format_delivery']


@dataclasses.dataclass(frozen=True)
class Delivery:
    """One topic: published (all publishers), written by the recorder, and the split of the
    difference (module docstring; ``None`` where a topic has several publishers)."""

    topic: str
    publishers: int
    published: int
    written: int
    before: int | None
    gaps: int | None
    tail: int | None

    @property
    def lost(self) -> int | None:
        """Messages lost: gaps + tail (None with several publishers)."""
        return None if self.gaps is None or self.tail is None else self.gaps + self.tail


def delivery_table(node_stats: Mapping[str, Mapping[str, Any]],
                   recorder_stats: Mapping[str, Any]) -> list[Delivery]:
    """One ``Delivery`` per topic the recorder recorded.

    Args:
        node_stats: node name -> that node's stats (``published``: topic -> count).
        recorder_stats: the recorder's stats (``written``: topic -> count; ``sequence``:
            topic -> publisher -> [first, last, count]; the publisher '' on a topic of one).
    """
    published: dict[str, dict[str, int]] = {}
    for node, st in node_stats.items():
        for topic, n in st.get('published', {}).items():
            published.setdefault(topic, {})[node] = int(n)
    rows = []
    for topic, written in sorted(recorder_stats.get('written', {}).items()):
        counts = published.get(topic, {})
        seqs = recorder_stats.get('sequence', {}).get(topic) or {}
        if isinstance(seqs, list):           # statistics of before per-publisher counts
            seqs = {'': seqs}
        parts = [_split(n, _sequence_of(node, seqs, len(counts)))
                 for node, n in counts.items()]
        known = counts and all(p is not None for p in parts)
        before, gaps, tail = ((sum(p[i] for p in parts if p is not None) for i in range(3))
                              if known else (None, None, None))
        rows.append(Delivery(topic, len(counts), sum(counts.values()), int(written), before,
                             gaps, tail))
    return rows


def _sequence_of(node: str, seqs: Mapping[str, Any], publishers: int) -> list[int] | None:
    """The sequence numbers the recorder saw from ``node`` ([] when it saw none; None when
    it cannot tell that node's apart)."""
    if publishers == 1 and list(seqs) in ([], ['']):
        return list(seqs.get('', []))
    for who, seq in seqs.items():
        if who and who.rsplit('/', 1)[-1] == node:
            return list(seq)
    return [] if '' not in seqs else None


def _split(published: int, seq: list[int] | None) -> tuple[int, int, int] | None:
    """(before, gaps, tail) of one publisher that published ``published`` messages, of which
    the recorder saw the sequence numbers ``seq`` ([first, last, count]; [] none)."""
    if seq is None:
        return None
    if not seq:
        return published, 0, 0
    first, last, got = (int(v) for v in seq)
    return first - 1, max(last - first + 1 - got, 0), max(published - last, 0)


def format_delivery(rows: list[Delivery]) -> str:
    """A plain-text table of ``rows``."""
    out = [f'{"topic":32s} {"published":>9s} {"written":>8s} {"before":>6s} {"lost":>5s}']
    for r in rows:
        lost = '-' if r.lost is None else str(r.lost)
        before = '-' if r.before is None else str(r.before)
        out.append(f'{r.topic:32s} {r.published:9d} {r.written:8d} {before:>6s} {lost:>5s}')
    return '\n'.join(out)
