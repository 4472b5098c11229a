"""The bag floor writes the very bag the nodes wrote."""

from __future__ import annotations

import pathlib

from rosbags.highlevel import AnyReader

from pam_bench.nodes.bag_floor import write_again


def _raw(bag: pathlib.Path) -> dict[str, list[tuple[int, bytes]]]:
    out: dict[str, list[tuple[int, bytes]]] = {}
    with AnyReader([bag]) as reader:
        for c, t, raw in reader.messages():
            out.setdefault(c.topic, []).append((t, bytes(raw)))
    return out


def test_the_demo_bag_written_again_is_the_same_bag(demo_bag: pathlib.Path,
                                                    tmp_path: pathlib.Path) -> None:
    """Every message of the demo bag, encoded and written again: the same stamps and bytes
    on every topic, so the floor writes what the recorder wrote."""
    seconds, n = write_again(demo_bag, tmp_path / 'again')
    before, after = _raw(demo_bag), _raw(tmp_path / 'again')
    assert sorted(after) == sorted(before)
    for topic, msgs in before.items():
        assert after[topic] == msgs, topic
    assert n == sum(len(m) for m in before.values()) and seconds > 0.0
