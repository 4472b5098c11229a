"""A node's diagnostics (REP-107): one status per concern, a steady summary, few log lines."""

from __future__ import annotations

import logging
from typing import Any

from diagnostic_msgs.msg import DiagnosticStatus

from pam_bench.runtime.diagnostics import Diagnostics


class _Logger:
    def __init__(self) -> None:
        self.lines: list[str] = []

    def info(self, m: str) -> None:
        self.lines.append(m)

    warning = error = info


class _Node:
    def __init__(self) -> None:
        self.log = _Logger()

    def get_fully_qualified_name(self) -> str:
        return '/valve_1'

    def get_logger(self) -> Any:
        return self.log


def test_a_repeat_is_counted_not_sent_and_the_summary_has_every_concern() -> None:
    sent: list[Any] = []
    node = _Node()
    d = Diagnostics(node, sent.append, 'lab/valve', 1.0)
    d.tick(0)
    assert [s.name for s in sent[-1].status] == ['valve_1: state']
    for _ in range(500):                                   # 500 bad commands
        d.report('inputs', DiagnosticStatus.ERROR, 'rejected voltage: nan', rejected_count=1)
    assert len(sent) == 2                                   # the summary, then one change
    assert len(node.log.lines) == 1                         # one line, not 500
    d.tick(500_000_000)
    assert len(sent) == 2                                   # not due yet
    d.tick(1_000_000_000)
    summary = sent[-1].status
    assert [s.name for s in summary] == ['valve_1: state', 'valve_1: inputs']
    assert {s.hardware_id for s in summary} == {'lab/valve'}
    inputs = {kv.key: kv.value for kv in summary[1].values}
    assert inputs['reports'] == '500' and summary[1].level == DiagnosticStatus.ERROR
    d.report('inputs', DiagnosticStatus.OK, 'inputs valid again')
    assert len(sent) == 4 and sent[-1].status[0].level == DiagnosticStatus.OK


def test_no_summary_when_the_period_is_zero() -> None:
    sent: list[Any] = []
    d = Diagnostics(_Node(), sent.append, 'x', 0.0)
    d.tick(0)
    d.tick(10**10)
    assert sent == []
    logging.getLogger(__name__).debug('none sent')
