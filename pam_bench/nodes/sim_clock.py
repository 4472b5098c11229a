"""sim_clock: advances /clock in lock-step with every participant (see ``runtime.base``).

It repeats t_0 until every participant has acknowledged it (all are up and their inputs are
matched), waits ``grace_s`` of wall time for the remaining matches, then publishes t_k+1 only
when every participant has acknowledged t_k. The step t_k+1 - t_k is ``exchange_step_s``, or
shorter when an acknowledgement asks for it (``max_next_step``).

It stops at ``duration_s`` or when an acknowledgement asks to stop (the sequencer's, when its
protocol ends: in the ack itself, so the last step is the same in every run). A last flush tick
at t_N + 1 ns lets every participant (the recorder above all) take in the data stamped t_N;
once all have acknowledged it the clock writes its ``RunSummary`` as JSON to ``summary_file``
(when set), prints it as one line and exits with the run's exit code. The rules (step
negotiation, flush tick, stop request, states) are ``sim.lockstep``. With ``realtime`` the
ticks are paced to the wall clock.

A second publisher of ``/clock`` in its domain (another run, a node started by hand) ends the
run at once, exit code 4, naming it: ``bringup.domains`` keeps pam_bench's own runs apart, and
this catches the rest.
"""

from __future__ import annotations

import collections
import math
import os
import time
from typing import Any

from pam_bench_interfaces.msg import ProtocolStatus, StepAck
from rosgraph_msgs.msg import Clock

from pam_bench.config import topics
from pam_bench.config.settings import ClockSettings
from pam_bench.runtime.base import RELIABLE, BenchNode, Spin
from pam_bench.runtime.intra import bus_publisher, bus_subscription
from pam_bench.runtime.messages import ack_of, time_of
from pam_bench.runtime.process import run_node
from pam_bench.sim.lockstep import (
    FLUSH_NS,
    ClockState,
    RunSummary,
    StopRequest,
    flush_tick,
    negotiate,
    request_ns,
)

__all__ = ['SimClock', 'windowed_rate', 'eta_text', 'ETA_WINDOW_S', 'main']

ETA_WINDOW_S = 30.0      # s of wall time the ETA's rate is taken over
GRAPH_CHECK_S = 1.0      # s of wall time between two looks for a foreign /clock publisher
FOREIGN_CODE = 4         # exit code of a run that met another run's clock in its domain
NAME_WAIT_S = 3.0        # s of wall time to wait for DDS to pass on a foreign publisher's name
UNKNOWN_NAME = '_NODE_NAME_UNKNOWN_'   # rmw's node name before the graph has caught up


def windowed_rate(history: collections.deque[tuple[float, float]], wall_s: float,
                  sim_s: float, window_s: float = ETA_WINDOW_S) -> float:
    """Sim seconds per wall second over about the last ``window_s`` of wall time.

    Appends the sample (``wall_s``, ``sim_s``) to ``history`` and drops samples older than the
    window (keeping one at or beyond its start), so the rate follows a change of protocol: a
    campaign's step records cost several times more wall time per sim second than its settled
    readings, and the run's mean rate would promise an early end.

    Returns:
        The rate, sim s / wall s (0 until two samples span some wall time).
    """
    history.append((wall_s, sim_s))
    while len(history) > 2 and wall_s - history[1][0] >= window_s:
        history.popleft()
    w0, s0 = history[0]
    return (sim_s - s0) / (wall_s - w0) if wall_s > w0 else 0.0


def eta_text(remaining_sim_s: float, rate: float) -> str:
    """``  ETA N s wall`` for ``remaining_sim_s`` at ``rate`` sim s per wall s; '' while the
    rate is not known yet (never ``inf``)."""
    if rate <= 0 or not math.isfinite(rate):
        return ''
    return f'  ETA {max(remaining_sim_s, 0.0) / rate:6.1f} s wall'


class SimClock(BenchNode):
    """Lock-step master clock: an ordinary bench node that steps nobody but publishes /clock."""

    SETTINGS = ClockSettings
    INTERRUPTED_CODE = 130

    def __init__(self, name: str = 'sim_clock', lean: bool | None = None, **kwargs: Any) -> None:
        """``lean``: driven by ``lean_spin`` (polls instead of timers); default: unless
        ``PAM_BENCH_EXECUTOR=single``. Under an rclpy executor pass ``lean=False``."""
        super().__init__(name, **kwargs)
        s: ClockSettings = self.settings
        self.step_s = s.exchange_step_s               # read by the composed runner
        self.participants = set(s.participants)
        self.duration_s = s.duration_s
        self.h_ns = round(self.step_s * 1e9)
        self.k = 0
        self.tick_ns = 0
        self.state = ClockState.WAITING
        self.stop_request: StopRequest | None = None
        self.summary: RunSummary | None = None
        self.acks: set[str] = set()
        self.next_step_ns = 0             # shortest step requested for the next tick
        self.nudges = 0                   # times the current tick was published again
        self.expected_total_s = self.duration_s
        self.paused = ''                 # the protocol's pause or suspension, while it lasts
        self.pub = bus_publisher(self, Clock, topics.CLOCK, RELIABLE)
        bus_subscription(self, StepAck, topics.ACK, self._on_ack, RELIABLE)
        bus_subscription(self, ProtocolStatus, topics.STATUS, self._on_status, RELIABLE)
        self.status_pub = bus_publisher(self, ProtocolStatus, topics.STATUS, RELIABLE)
        self.t_wall0 = time.monotonic()
        self.t_run0 = 0.0
        self.last_progress = time.monotonic()
        self.rate_history: collections.deque[tuple[float, float]] = collections.deque()
        self.last_tick_wall = time.monotonic()
        self.ready_at: float | None = None    # wall time when all were ready (lean mode)
        self._t0_sent = False                 # lean mode: t_0 published once
        self.last_graph_check = 0.0
        self.foreign_seen_at: float | None = None   # wall time a foreign /clock was first seen
        self.lean = (os.environ.get('PAM_BENCH_EXECUTOR') != 'single') if lean is None else lean
        if not self.lean:
            self.timer = self.create_timer(0.05, self._on_timer)

    def spin_mode(self) -> Spin:
        """Lean: its subscriptions and ``lean_poll``; else rclpy's executor and timers."""
        return Spin.LEAN if self.lean else Spin.EXECUTOR

    @property
    def flushing(self) -> bool:
        """The flush tick is out."""
        return self.state == ClockState.FLUSHING

    @property
    def done(self) -> bool:
        """The run has ended."""
        return self.state == ClockState.DONE

    def lean_poll(self) -> None:
        """What the timers do, called by ``lean_spin`` at every wake-up (>= every 50 ms).

        While waiting, t_0 goes out at the first poll and again every 50 ms, and the clock is
        ready at the first poll that finds every participant's acknowledgement, not at the
        next 50 ms mark (in one process, three such marks were 0.15 s of the demo's 1.5 s)."""
        now = time.monotonic()
        self._check_foreign(now)
        if self.ready_at is None and self.state == ClockState.WAITING and (
                not self._t0_sent or self.acks >= self.participants):
            self._t0_sent = True
            self._on_timer()
            now = time.monotonic()           # ready now: no grace (one process) starts now
        if self.ready_at is not None:
            if self.state == ClockState.GRACE and now - self.ready_at >= self.settings.grace_s:
                self.t_run0 = now
                self.state = ClockState.RUNNING
                self._advance()
            elif self.state in (ClockState.RUNNING, ClockState.FLUSHING):
                self._check_progress(now)
            return
        if now - self.last_tick_wall >= 0.05:
            self._on_timer()

    def _publish(self) -> None:
        self.last_tick_wall = time.monotonic()
        self.nudges = 0
        self.pub.publish(Clock(clock=time_of(self.tick_ns)))

    def _check_foreign(self, now: float) -> None:
        """Once a second: end the run when another node publishes ``/clock`` here.

        The graph can list a publisher before its node's name arrives; the check then looks
        again every 0.1 s, for up to ``NAME_WAIT_S``, so that the message names the node.
        """
        wait = GRAPH_CHECK_S if self.foreign_seen_at is None else 0.1
        if now - self.last_graph_check < wait or self.done:
            return
        self.last_graph_check = now
        if self.count_publishers(topics.CLOCK) <= 1:
            return
        infos = self.get_publishers_info_by_topic(topics.CLOCK)
        if self.foreign_seen_at is None:
            self.foreign_seen_at = now
        if (any(i.node_name == UNKNOWN_NAME for i in infos)
                and now - self.foreign_seen_at < NAME_WAIT_S):
            return
        others = sorted({f'{i.node_namespace.rstrip("/")}/{i.node_name}'
                         if i.node_name != UNKNOWN_NAME else 'a node whose name DDS has not given'
                         for i in infos})
        self._abort(f'another node publishes {topics.CLOCK} in ROS_DOMAIN_ID '
                    f'{os.environ.get("ROS_DOMAIN_ID", "0")} (publishers: {", ".join(others)}):'
                    ' another run shares this domain; this run stops', FOREIGN_CODE)

    def _on_timer(self) -> None:
        now = time.monotonic()
        self._check_foreign(now)
        if self.state == ClockState.WAITING:
            if self.acks >= self.participants:
                self.state = ClockState.GRACE
                if self.lean:
                    self.ready_at = now
                    return
                self.timer.cancel()
                grace = self.settings.grace_s
                self.timer = self.create_timer(grace if grace > 0 else 1e-3, self._start)
            else:
                self._publish()     # repeat t_0 until all are up
                if now - self.t_wall0 > self.settings.stall_timeout_s:
                    self._finish(f'participants never ready: '
                                 f'{sorted(self.participants - self.acks)}', 2)
            return
        if self.state in (ClockState.RUNNING, ClockState.FLUSHING):
            self._check_progress(now)

    def _check_progress(self, now: float) -> None:
        """Nudge, then give up on, a tick that is not acknowledged."""
        waited = now - self.last_tick_wall
        if waited > self.settings.stall_timeout_s:
            self._stall()
        elif waited > (self.nudges + 1) * self.settings.nudge_s:
            # again every nudge_s: under load a reader can match later than one nudge, and the
            # outputs sent again with it are lost as the first ones were
            self.nudges += 1
            self.pub.publish(Clock(clock=time_of(self.tick_ns)))

    def _stall(self) -> None:
        """A participant did not acknowledge in time: publish why, end the run."""
        self._abort(f'lock-step stalled at t = {self.tick_ns * 1e-9:.3f} s: no '
                    f'acknowledgement from {", ".join(sorted(self.participants - self.acks))}'
                    f' within {self.settings.stall_timeout_s:g} s (node dead or hung)', 3)

    def _abort(self, reason: str, code: int) -> None:
        """Publish ``reason`` as an aborted status (the bag holds it), end the run."""
        status = ProtocolStatus(state=ProtocolStatus.STATE_ABORTED, phase='aborted',
                                reason=reason)
        status.header.stamp = time_of(self.tick_ns)
        self.status_pub.publish(status)
        time.sleep(0.2)                 # let the recorder take the status in
        self._finish(reason, code)

    def _start(self) -> None:
        self.timer.cancel()
        self.timer = self.create_timer(0.25, self._on_timer)
        self.t_run0 = time.monotonic()
        self.state = ClockState.RUNNING
        self._advance()

    def _advance(self) -> None:
        if self.done:
            return
        t_s = self.tick_ns * 1e-9
        if self.duration_s > 0.0 and t_s >= self.duration_s - 1e-12:
            self._flush(StopRequest(0, 'duration reached'))
            return
        step = negotiate(self.h_ns, (self.next_step_ns,),
                         round(self.duration_s * 1e9) - self.tick_ns
                         if self.duration_s > 0.0 else None)
        if self.settings.realtime:
            lag = (self.tick_ns + step) * 1e-9 - (time.monotonic() - self.t_run0)
            if lag > 0:
                time.sleep(lag)
        self.k += 1
        self.tick_ns += step
        self.next_step_ns = 0
        self.acks = set()
        self._publish()
        self._progress()

    def _flush(self, stop: StopRequest) -> None:
        """Publish the flush tick t_N + 1 ns; finish once everyone acknowledged it."""
        if self.flushing:
            return
        self.state = ClockState.FLUSHING
        self.flush_request = stop
        self.tick_ns = flush_tick(self.tick_ns)
        self.acks = set()
        self._publish()

    def _on_ack(self, msg: Any) -> None:
        ack = ack_of(msg)
        if ack.t_ns != self.tick_ns:
            return
        self.acks.add(ack.node)
        if ack.max_next_step_s > 0.0:
            self.next_step_ns = negotiate(request_ns(ack.max_next_step_s), (self.next_step_ns,))
        if ack.stop is not None and not self.flushing:
            self.stop_request = ack.stop
        if len(self.acks) < len(self.participants):    # cheap: most acks end here
            return
        if not (self.state in (ClockState.RUNNING, ClockState.FLUSHING) and self.k > 0
                and self.acks >= self.participants):
            return
        if self.stop_request is not None and not self.flushing:
            self._flush(self.stop_request)
            return
        if self.flushing:
            self._finish(self.flush_request.reason, self.flush_request.exit_code)
        else:
            self._advance()

    def _on_status(self, msg: ProtocolStatus) -> None:
        if msg.remaining > 0.0:
            self.expected_total_s = msg.elapsed + msg.remaining
        self.paused = msg.reason if msg.phase == 'paused' else ''
        # ending the run is asked for in the sequencer's StepAck, not here (no topic race)

    def _progress(self) -> None:
        now = time.monotonic()
        period = self.settings.progress_period_s
        if period <= 0 or now - self.last_progress < period:
            return
        self.last_progress = now
        t = self.tick_ns * 1e-9
        wall = now - self.t_run0
        rtf = t / wall if wall > 0 else 0.0
        total = self.expected_total_s
        recent = windowed_rate(self.rate_history, wall, t)
        if self.paused:                  # no ETA: nobody knows when it resumes
            print(f'[sim {t:9.2f} s]  wall {wall:7.1f} s  x{rtf:6.1f} real time  '
                  f'{self.paused}', flush=True)
        elif total > 0:
            print(f'[sim {t:9.2f} / {total:9.2f} s  {100 * t / total:5.1f} %]  wall {wall:7.1f} '
                  f's  x{rtf:6.1f} real time' + eta_text(total - t, recent or rtf), flush=True)
        else:
            print(f'[sim {t:9.2f} s]  wall {wall:7.1f} s  x{rtf:6.1f} real time', flush=True)

    def _finish(self, reason: str, code: int) -> None:
        wall = max(time.monotonic() - self.t_run0, 1e-9) if self.t_run0 else 0.0
        sim_s = (self.tick_ns - (FLUSH_NS if self.flushing else 0)) * 1e-9
        self.state = ClockState.DONE
        self.exit_code = code
        self.summary = RunSummary(code, self.k, sim_s, wall, reason)
        if self.settings.summary_file:
            with open(self.settings.summary_file, 'w', encoding='utf-8') as fh:
                fh.write(self.summary.to_json())
        print(self.summary.line(), flush=True)
        raise SystemExit(code)


def main(args: list[str] | None = None) -> None:
    """Run the clock until the scene ends; exit code 0 when it ended normally."""
    run_node(SimClock, args)


if __name__ == '__main__':
    main()
