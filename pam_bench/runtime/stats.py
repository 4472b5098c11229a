"""What a node tells about its run: messages it published on DDS, and its tick periods.

On a wall clock every node counts what it puts on DDS per topic (with the sequence numbers the
recorder sees, the counts say whether a message was lost) and, when it ticks, the periods of
its loop, streamed into fixed memory (``analysis.timing.PeriodStats``: a six-hour run keeps as
little as a short one). Both go to ``stats_file`` (JSON) when the node stops.
"""

from __future__ import annotations

import json
import os
import time
from typing import Any

from pam_bench.analysis.timing import PeriodStats
from pam_bench.runtime.core import NodeCore

__all__ = ['Stats', 'ACK_WAIT_S']

ACK_WAIT_S = 0.5
"""How long a stopping node lets reliable subscribers acknowledge what it published, over all
its publishers (s). Fast DDS's readers acknowledge when the writer's heartbeat asks (every 3 s
by default), so the wait often runs its whole budget even with every subscriber there, and a
subscriber that has gone without the writer knowing yet never acknowledges: one budget per
node, or per process (``ack_until_s``), not per publisher, which cost a stopping emulator 0.5 s
per measured topic (docs/long_runs.md, "make test made shorter")."""


class Stats(NodeCore):
    """Publish counts and loop periods (module docstring)."""

    def _init_stats(self) -> None:
        self.published: dict[str, int] = {}         # topic -> messages published on DDS
        self._counted_pubs: list[Any] = []
        self.periods: PeriodStats | None = None     # set by the loop that ticks the node
        self.dropped_ticks = 0                      # ticks its loop skipped, too far behind
        # when set: the monotonic time (s) by which a stop ends its wait for acknowledgments,
        # one budget shared by the nodes of one process (bringup.emulator)
        self.ack_until_s: float | None = None

    def count_periods(self, period_s: float) -> None:
        """Keep the statistics of a loop ticking every ``period_s``."""
        self.periods = PeriodStats(period_s)

    def count_tick(self) -> None:
        """One tick of the node's loop, now (monotonic); the diagnostics summary when due."""
        if self.periods is not None:
            self.periods.tick(time.monotonic_ns())
        self.diagnostics.tick(int(self.get_clock().now().nanoseconds))

    def counted(self, pub: Any, topic: str) -> Any:
        """Count what ``pub`` puts on DDS (``published``). Returns ``pub``."""
        name = self.resolve_topic_name(topic)
        self.published.setdefault(name, 0)
        send = pub.publish
        dds = getattr(pub, 'dds', None)               # a bus publisher: DDS only when external

        def publish(msg: Any, *args: Any) -> None:
            if dds is None or pub.external:
                self.published[name] += 1
            send(msg, *args)

        pub.publish = publish
        self._counted_pubs.append(pub)
        return pub

    def wall_stats(self) -> dict[str, Any]:
        """What this node published on DDS (topic -> count) and its tick periods."""
        out: dict[str, Any] = {'node': self._fqn, 'published': dict(self.published)}
        per = self.periods.stats() if self.periods is not None else None
        if per is not None:
            out['periods'] = per
            out['dropped_ticks'] = self.dropped_ticks
        return out

    def write_stats(self) -> None:
        """Write ``wall_stats`` to the settings' ``stats_file`` (when set)."""
        path = getattr(self.settings, 'stats_file', '')
        if path:
            tmp = f'{path}.part'
            with open(tmp, 'w', encoding='utf-8') as fh:
                json.dump(self.wall_stats(), fh)
            os.replace(tmp, path)

    def wait_acknowledged(self) -> None:
        """Let reliable subscribers acknowledge what was published (a recorder gets the last
        messages), until ``ack_until_s`` or for ``ACK_WAIT_S`` over all publishers."""
        from rclpy.duration import Duration
        until = time.monotonic() + ACK_WAIT_S if self.ack_until_s is None else self.ack_until_s
        for pub in self._counted_pubs:
            left = until - time.monotonic()
            if left <= 0.0:
                return
            dds = getattr(pub, 'dds', pub)
            try:
                dds.wait_for_all_acked(Duration(nanoseconds=round(left * 1e9)))
            except Exception:  # noqa: BLE001 - best effort at shutdown
                pass
