"""The limit table's bag floor writes the very bag the nodes wrote, and its twin and physics
figures are measured."""

from __future__ import annotations

import pathlib

from rosbags.highlevel import AnyReader

from benchmarks.limits import bag_alone_s, physics_share, twin_run_s


def _raw(bag: pathlib.Path) -> dict[str, list[tuple[int, bytes]]]:
    out: dict[str, list[tuple[int, bytes]]] = {}
    with AnyReader([bag]) as reader:
        for c, t, raw in reader.messages():
            out.setdefault(c.topic, []).append((t, bytes(raw)))
    return out


def test_the_bag_alone_is_the_nodes_bag_again(demo_bag: pathlib.Path,
                                              tmp_path: pathlib.Path) -> None:
    """Every message of the demo bag, encoded and written again: the same stamps and bytes
    on every topic, so the floor writes what the recorder wrote."""
    seconds, n = bag_alone_s(demo_bag, tmp_path / 'again')
    before, after = _raw(demo_bag), _raw(tmp_path / 'again')
    assert sorted(after) == sorted(before)
    for topic, msgs in before.items():
        assert after[topic] == msgs, topic
    assert n == sum(len(m) for m in before.values()) and seconds > 0.0


def test_the_twin_and_its_physics_share_are_measured() -> None:
    """The demo on the twin takes time, and the physics is a share of it, neither none nor
    all (the sequencer and the twin's loop are Python around it)."""
    assert twin_run_s('demo') > 0.0
    share = physics_share('demo')
    assert 0.05 < share < 0.95, share
