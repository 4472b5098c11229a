"""A recorder killed with SIGKILL: the bag says so in one line, bag-repair keeps every flushed
message and leaves a bag both readers open."""

from __future__ import annotations

import os
import pathlib
import signal
import subprocess
import sys
import time

import pytest

from pam_bench.bags.bag_repair import repair_bag
from pam_bench.bags.bagread import open_bag
from pam_bench.bags.errors import BagError
from test.helpers import bag_messages


def _start(args: list[str]) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, '-m', 'pam_bench.cli', *args],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True)


@pytest.mark.wallclock
def test_sigkilled_recorder_bag_is_repaired(tmp_path: pathlib.Path, ros_domain: int) -> None:
    bag = tmp_path / 'bag'
    emu = _start(['emulate', 'demo'])
    rec = None
    try:
        time.sleep(2.0)
        rec = _start(['record', 'load_cell_1/force', 'valve_1/pressure', '--out', str(bag)])
        end = time.monotonic() + 20.0
        while time.monotonic() < end:        # until a flush (1 s) has written some data
            mcap = list(bag.glob('.part_0/*.mcap'))
            if mcap and mcap[0].stat().st_size > 200_000:
                break
            time.sleep(0.1)
        os.killpg(rec.pid, signal.SIGKILL)
        rec.wait(timeout=10)
    finally:
        for p in (emu, rec):
            if p is not None and p.poll() is None:
                os.killpg(p.pid, signal.SIGINT)
                p.wait(timeout=10)
    with pytest.raises(BagError, match='bag-repair'):
        open_bag(bag)
    report = repair_bag(bag)
    assert report.needed and report.broken_copy is not None and report.broken_copy.exists()
    assert report.kept.get('/load_cell_1/force', 0) > 500, report
    forces = bag_messages(bag, '/load_cell_1/force')
    assert len(forces) == report.kept['/load_cell_1/force']
    stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in forces]
    assert stamps == sorted(stamps)
    from mcap.reader import make_reader
    assert [f.name for f in bag.glob('*.mcap')] == ['bag.mcap']
    with open(bag / 'bag.mcap', 'rb') as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None and sum(summary.statistics.channel_message_counts.values()) == \
        sum(report.kept.values())
    assert not repair_bag(bag).needed               # a second repair has nothing to do
