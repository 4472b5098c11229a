"""A node's diagnostics as REP-107 asks: one status per concern, a summary at a steady rate.

Each node keeps one status per concern (``state``, ``inputs``, ``torque limit``, ...): its
level, message, values and how often it was reported. A report publishes the node's statuses
at once only when a concern's level changes; otherwise it is counted and goes out with the
next summary. The summary (every ``period_s`` of the node's clock: sim time in lock-step, the
wall otherwise) publishes every concern, so a monitor (rqt_robot_monitor, Foxglove's
diagnostics panel) never marks a running node stale. Each status is named
``<node>: <concern>`` and carries the node's ``hardware_id``. Log lines follow the same
rule: a change of level is logged at once, a repeat at most once per wall second with the
number of repeats since, so 500 rejected commands make a few lines, not 500.

A status says the present condition: a concern reported as passing (``passing=True``, a
rejected input) goes back to OK at the first summary that finds no new report of it since the
last one, so a run of valid commands after one bad one does not stay ERROR.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from pam_bench.runtime.messages import time_of

__all__ = ['Diagnostics', 'LOG_EVERY_S']

LOG_EVERY_S = 1.0
"""Least wall time between two log lines of one concern at one level."""


@dataclasses.dataclass
class _Concern:
    level: bytes
    message: str
    values: dict[str, Any]
    count: int = 0
    logged_at: float = -1e9
    unlogged: int = 0
    passing: bool = False
    count_at_summary: int = 0


class Diagnostics:
    """The diagnostics of one node (module docstring).

    Args:
        node: the rclpy node (its logger, its name).
        publish: sends a ``DiagnosticArray`` (the node's /diagnostics publisher).
        hardware_id: REP-107 hardware id of every status.
        period_s: summary period on the node's clock, s (0: no summary).
    """

    def __init__(self, node: Any, publish: Any, hardware_id: str, period_s: float) -> None:
        self.node = node
        self.publish = publish
        self.hardware_id = hardware_id
        self.period_ns = round(period_s * 1e9)
        self.name = node.get_fully_qualified_name().lstrip('/')
        self.concerns: dict[str, _Concern] = {'state': _Concern(DiagnosticStatus.OK,
                                                                 'running', {})}
        self.next_ns: int | None = None
        self.stamp_ns = 0

    def report(self, concern: str, level: bytes, message: str, passing: bool = False,
               **values: Any) -> None:
        """A status of ``concern``: sent at once when its level changed, else with the next
        summary; logged at once on a change, else at most once a wall second. ``passing``:
        an event, not a condition (module docstring)."""
        c = self.concerns.get(concern)
        changed = c is None or c.level != level
        if c is None:
            c = self.concerns[concern] = _Concern(level, message, dict(values))
        c.level, c.message, c.values = level, message, dict(values)
        c.passing = passing
        c.count += 1
        now = time.monotonic()
        if changed or now - c.logged_at >= LOG_EVERY_S:
            more = f' ({c.unlogged} more since)' if c.unlogged else ''
            log = self.node.get_logger()       # one call site per severity (rclpy asks it)
            if level == DiagnosticStatus.OK:
                log.info(message + more)
            elif level == DiagnosticStatus.WARN:
                log.warning(message + more)
            else:
                log.error(message + more)
            c.logged_at, c.unlogged = now, 0
        else:
            c.unlogged += 1
        if changed:
            self.send([concern])

    def tick(self, t_ns: int) -> None:
        """The node's clock reached ``t_ns``: the summary when it is due."""
        self.stamp_ns = t_ns
        if not self.period_ns:
            return
        if self.next_ns is None:
            self.next_ns = t_ns
        if t_ns >= self.next_ns:
            self.next_ns = t_ns + self.period_ns
            for name, c in list(self.concerns.items()):
                if c.passing and c.level != DiagnosticStatus.OK and \
                        c.count == c.count_at_summary:
                    self.report(name, DiagnosticStatus.OK, 'none rejected since the last '
                                'summary', **c.values)
                c.count_at_summary = c.count
            self.send(list(self.concerns))

    def send(self, concerns: list[str]) -> None:
        """Publish the statuses of ``concerns`` in one DiagnosticArray."""
        arr = DiagnosticArray()
        arr.header.stamp = time_of(self.stamp_ns)
        out = []
        for name in concerns:
            c = self.concerns[name]
            st = DiagnosticStatus(level=c.level, name=f'{self.name}: {name}', message=c.message,
                                  hardware_id=self.hardware_id)
            st.values = [KeyValue(key='reports', value=str(c.count))] + [
                KeyValue(key=k, value=str(v)) for k, v in c.values.items()]
            out.append(st)
        arr.status = out
        self.publish(arr)
