"""What a recorder got against what was published: a count per topic, no guessing.

Each node on a wall clock counts the messages it puts on DDS per topic (``published``); the
recorder counts what it wrote and keeps the first and last publication sequence number it
received per topic with how many it received. For a topic with one publisher (every topic of
the contract but /diagnostics) the DDS sequence numbers run 1, 2, ... so:

* ``before``: messages published before the recorder matched (sequence numbers below the
  first it saw): not recorded, not lost;
* ``gaps``: messages missing between the first and the last it saw: lost;
* ``tail``: messages published after the last it saw (``published - last``): lost, as the
  recorder is stopped last.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping
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


def delivery_table(node_stats: Iterable[Mapping[str, Any]],
                   recorder_stats: Mapping[str, Any]) -> list[Delivery]:
    """One ``Delivery`` per topic the recorder recorded.

    Args:
        node_stats: every publishing node's stats (``published``: topic -> count).
        recorder_stats: the recorder's stats (``written``: topic -> count; ``sequence``:
            topic -> [first, last, count]).
    """
    published: dict[str, list[int]] = {}
    for st in node_stats:
        for topic, n in st.get('published', {}).items():
            published.setdefault(topic, []).append(int(n))
    rows = []
    for topic, written in sorted(recorder_stats.get('written', {}).items()):
        counts = published.get(topic, [])
        seq = recorder_stats.get('sequence', {}).get(topic)
        before = gaps = tail = None
        if len(counts) == 1:
            if seq is None:
                before, gaps, tail = counts[0], 0, 0
            else:
                first, last, got = (int(v) for v in seq)
                before, gaps, tail = first - 1, last - first + 1 - got, counts[0] - last
        rows.append(Delivery(topic, len(counts), sum(counts), int(written), before, gaps,
                             tail))
    return rows


def format_delivery(rows: list[Delivery]) -> str:
    """A plain-text table of ``rows``."""
    out = [f'{"topic":32s} {"published":>9s} {"written":>8s} {"before":>6s} {"lost":>5s}']
    for r in rows:
        lost = '-' if r.lost is None else str(r.lost)
        before = '-' if r.before is None else str(r.before)
        out.append(f'{r.topic:32s} {r.published:9d} {r.written:8d} {before:>6s} {lost:>5s}')
    return '\n'.join(out)
