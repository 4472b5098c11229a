"""recorder: writes the contract topics to a rosbag2 directory (metadata.yaml + .mcap).

Messages stay CDR bytes end to end (raw subscriptions, rosbags writer); the log time of each
message is its header stamp, i.e. sim time. Topics published at every step are recorded in
lock-step: at its step to t_k the recorder writes /clock and every step topic stamped t_(k-1),
with any sub-step samples published between t_(k-2) and t_(k-1) (it cannot step before it holds
them, so it never falls behind nor loses data). The clock's
flush tick t_N + 1 ns makes it write the t_N data and then drop anything stamped later, so the
recorded payloads of a scene are the same in every run. Event topics (points, status,
diagnostics) are written as they come. The bag is closed valid at the end of the scene and on
SIGINT or SIGTERM.

On a wall clock (``lockstep: false``; ``pam-bench record``) every topic is written as it
arrives: log time = receive time on the wall clock (the middleware's receive stamp), header
stamps untouched. Each subscription matches its publishers' QoS (reliable unless a publisher
is best effort, checked every ``discovery_period_s``); with ``record_all`` every topic that
appears is recorded, like ``ros2 bag record -a``. Per topic the recorder counts what it wrote
and the publication sequence numbers it saw, so a gap (a lost message) is counted, not
guessed (``stats_file``). The pending chunk is flushed to disk every ``flush_period_s``: after a
SIGKILL at most that much is lost and ``pam-bench bag-repair`` rebuilds the index and
metadata.yaml.
"""

from __future__ import annotations

import datetime
import functools
import itertools
import json
import pathlib
import sys
import time
from typing import Any

import yaml
from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message

from pam_bench.bags.baginfo import END_KEY, RUN_KEY
from pam_bench.bags.splitwriter import DiskFull, SplitWriter
from pam_bench.bags.types import bench_typestore, typestore_of
from pam_bench.config.settings import RecorderSettings
from pam_bench.config.topics import in_namespace
from pam_bench.runtime import cdr
from pam_bench.runtime.base import BenchNode
from pam_bench.runtime.intra import bus_subscription
from pam_bench.runtime.messages import (
    ForceSamples,
    message_class,
    stamp_of_cdr,
    stamp_of_msg,
)
from pam_bench.runtime.process import run_node
from pam_bench.runtime.qos import bag_qos, lockstep_offer
from pam_bench.sim.lockstep import StopRequest

__all__ = ['Recorder', 'main']

KEEP_ALL = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                      history=HistoryPolicy.KEEP_ALL, durability=DurabilityPolicy.VOLATILE)


class Recorder(BenchNode):
    """Raw-bytes rosbag2 MCAP recorder."""

    SETTINGS = RecorderSettings
    GRACEFUL_STOP = True    # SIGINT/SIGTERM end the loop between writes, never inside one

    def __init__(self, name: str = 'recorder', **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        s: RecorderSettings = self.settings
        out = s.out_dir
        step_topics, event_topics = s.step_topics, s.event_topics
        self.record_all = s.record_all
        self.flush_period_s = s.flush_period_s
        self.run_yaml = s.run_yaml
        self.end_file = s.end_file
        self.topic_names = [t for t in s.topic_names if t]
        self.discovery_period_s = s.discovery_period_s
        # lock-step: the topics are known now, and their types alone are read (a wall-clock
        # recorder may meet any type later: the whole store)
        self.store = (typestore_of(tuple(sorted({e.partition(':')[2]
                                                 for e in (*step_topics, *event_topics) if e})))
                      if self.lockstep else bench_typestore())
        path = pathlib.Path(out)
        path.parent.mkdir(parents=True, exist_ok=True)
        writer = SplitWriter(path, compress=s.compress, max_bytes=int(s.max_bag_size_bytes),
                             max_duration_ns=round(s.max_bag_duration_s * 1e9),
                             min_free_bytes=int(s.min_free_bytes))
        writer.open()
        if self.run_yaml:
            writer.set_custom_data(RUN_KEY, self.run_yaml)
        self.writer: SplitWriter | None = writer
        self.count = 0
        self.exit_code = 0
        self.end_ns: int | None = None
        self.connections: dict[str, str] = {}       # topic -> message type
        self._trim: dict[str, str] = {}
        self._encoders: dict[str, Any] = {}         # step topic -> CDR of its objects
        self._next_flush = time.monotonic() + self.flush_period_s
        step_topics = [e for e in step_topics if e]
        event_topics = [e for e in event_topics if e]
        for entry in list(step_topics) + list(event_topics) if self.lockstep else []:
            topic, msgtype = self._split(entry)
            self._connect(topic, msgtype, [lockstep_offer(topic, entry in step_topics)])
        self.step_order = []
        self.written: dict[str, int] = {}
        # topic -> publisher -> [first, last, count] of the sequence numbers seen (the
        # publisher is '' on a topic of one; on /diagnostics, the node its statuses name)
        self.sequence: dict[str, dict[str, list[int]]] = {}
        self.last_status: tuple[int, str] | None = None    # (state, reason) recorded last
        self._wall_subs: dict[str, tuple[Any, str, bool]] = {}   # topic -> (sub, type, BE)
        self.subscriptions_version = 0
        if not self.lockstep:
            for entry in list(step_topics) + list(event_topics):
                topic, msgtype = self._split(entry)
                if topic != '/clock':
                    self._subscribe(topic, msgtype, best_effort=False)
            self._next_discovery = 0.0
            self._next_flush = time.monotonic() + self.flush_period_s
            print(f'recorder: recording {len(self._wall_subs)} topics'
                  + (' and every topic that appears' if self.record_all else '')
                  + f' into {path}', flush=True)
            return
        for entry in step_topics:
            topic, msgtype = self._split(entry)
            if topic == '/clock':
                continue
            self.step_order.append(topic)
            self.sync_input(message_class(msgtype), topic, raw=True, samples=True, stamped=True,
                            blocks=True)
        for entry in event_topics:
            topic, msgtype = self._split(entry)
            bus_subscription(self, message_class(msgtype), topic,
                             functools.partial(self._write_any, topic), KEEP_ALL, raw=True)
        self.start_lockstep()

    def _connect(self, topic: str, msgtype: str, offered: list[Any]) -> None:
        """A connection of the bag, with the QoS profiles its publishers offer (rclpy
        ``QoSProfile``s), stored as rosbag2 stores them: a player restores a latched topic."""
        assert self.writer is not None
        self.writer.add_connection(topic, msgtype, typestore=self.store,
                                   offered_qos_profiles=[bag_qos(q) for q in offered])
        self.connections[topic] = msgtype

    def _offered(self, topic: str) -> list[Any]:
        """The QoS profiles the publishers of ``topic`` offer now (from the graph)."""
        try:
            return [i.qos_profile for i in self.get_publishers_info_by_topic(topic)]
        except Exception:  # noqa: BLE001 - a graph query must not end a callback
            return []

    # --- wall clock ---------------------------------------------------------------------
    def _subscribe(self, topic: str, msgtype: str, best_effort: bool) -> None:
        """(Re)subscribe ``topic`` raw, reliable or best effort, keeping up to 1000."""
        old = self._wall_subs.pop(topic, None)
        if old is not None:
            self.destroy_subscription(old[0])
        offered = self._offered(topic)
        if topic not in self.connections and offered:  # else at its first message (as
            self._connect(topic, msgtype, offered)        # rosbag2, once it has publishers)
        qos = QoSProfile(depth=1000, history=HistoryPolicy.KEEP_LAST,
                         durability=DurabilityPolicy.VOLATILE,
                         reliability=ReliabilityPolicy.BEST_EFFORT if best_effort
                         else ReliabilityPolicy.RELIABLE)
        callback = functools.partial(self._on_wall, topic)
        callback.with_info = True        # type: ignore[attr-defined]
        sub = self.create_subscription(message_class(msgtype), topic, callback, qos, raw=True)
        self._wall_subs[topic] = (sub, msgtype, best_effort)
        self.written.setdefault(topic, 0)
        self.subscriptions_version += 1

    def _on_wall(self, topic: str, data: bytes, info: dict[str, Any] | None = None) -> None:
        """Write one message at its receive time; keep its publication sequence number."""
        if self.writer is None:
            return
        if topic not in self.connections:
            self._connect(topic, self._wall_subs[topic][1], self._offered(topic))
        t = (info or {}).get('received_timestamp') or time.time_ns()
        try:
            self.writer.write(topic, int(t), bytes(data))
        except DiskFull as exc:
            self._disk_full(exc)
            return
        self.count += 1
        self.written[topic] += 1
        if self._wall_subs[topic][1] == STATUS_TYPE:        # how the protocol ends (_end)
            self.last_status = status_of(data)
        seq = (info or {}).get('publication_sequence_number')
        if seq:
            per = self.sequence.setdefault(topic, {})
            who = publisher_of(data) if self._wall_subs[topic][1] == DIAGNOSTICS_TYPE else ''
            s = per.get(who)
            if s is None:
                per[who] = [seq, seq, 1]
            else:
                s[0], s[1], s[2] = min(s[0], seq), max(s[1], seq), s[2] + 1

    def lean_poll(self) -> None:
        """Wall clock: discovery (new topics, publishers' QoS) and the periodic flush; after
        a full disk, the exit (code 2)."""
        if self.exit_code:
            raise SystemExit(self.exit_code)
        if self.lockstep or self.writer is None:
            return
        now = time.monotonic()
        if now >= self._next_flush:
            self._next_flush = now + self.flush_period_s
            self.flush()
        if now < self._next_discovery:
            return
        self._next_discovery = now + self.discovery_period_s
        wanted = {n if n.startswith('/') else '/' + n for n in self.topic_names if n}
        if self.record_all or wanted - set(self._wall_subs):
            for topic, types in self.get_topic_names_and_types():
                if topic not in self._wall_subs and types and (
                        topic in wanted or self.record_all and not topic.startswith('/_')):
                    try:
                        self._subscribe(topic, types[0], best_effort=False)
                    except Exception as exc:  # noqa: BLE001 - an unknown type: say it, go on
                        self.connections.pop(topic, None)
                        self._wall_subs[topic] = (None, types[0], False)
                        self.get_logger().warning(f'not recording {topic} ({types[0]}): {exc}')
        for topic, (sub, msgtype, best_effort) in list(self._wall_subs.items()):
            if sub is None:
                continue
            infos = self.get_publishers_info_by_topic(topic)
            be = any(i.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT for i in infos)
            if infos and be != best_effort:
                self._subscribe(topic, msgtype, best_effort=be)

    def flush(self) -> None:
        """Write the pending chunk and flush the file: a SIGKILL loses at most what came
        since (``pam-bench bag-repair`` rebuilds the rest)."""
        if self.writer is not None:
            self.writer.flush()

    def wall_stats(self) -> dict[str, Any]:
        """Written counts and the publication sequence numbers seen, per topic."""
        out = super().wall_stats()
        out.update(written=dict(self.written),
                   sequence={k: {who: list(v) for who, v in per.items()}
                             for k, per in self.sequence.items()})
        return out

    def _split(self, entry: str) -> tuple[str, str]:
        """(topic, type) of a ``topic:type`` entry, the topic in the recorder's namespace
        (``config.topics.in_namespace``: a bench started under ``__ns`` records its own)."""
        topic, _, msgtype = entry.partition(':')
        if not msgtype:
            raise ValueError(f'recorder topic entry {entry!r} must be topic:package/msg/Type')
        return in_namespace(topic, self.get_namespace()), msgtype

    def _write(self, topic: str, t_ns: int, data: bytes) -> None:
        if self.writer is not None and (self.end_ns is None or t_ns <= self.end_ns):
            try:
                self.writer.write(topic, t_ns, bytes(data))
            except DiskFull as exc:
                self._disk_full(exc)
                return
            self.count += 1

    def _disk_full(self, exc: DiskFull) -> None:
        """The disk is (nearly) full: one line, the bag closed valid with what it holds, and
        the run ended (lock-step: a stop request to the clock; wall clock: exit code 2, and
        the runner stops the controllers, which vent)."""
        reason = f'disk full: {exc.strerror}; the bag is closed with the {self.count} ' \
            'messages it holds'
        print(f'recorder: error: {reason}', file=sys.stderr, flush=True)
        self.diagnose(DiagnosticStatus.ERROR, reason)
        self.close()
        if self.lockstep:
            self.stop_request = StopRequest(2, f'recorder: {reason}')
        else:
            self.exit_code = 2

    def _write_any(self, topic: str, data: Any) -> None:
        """Write CDR bytes (from DDS) or a message object (from the intra-process bus)."""
        if isinstance(data, (bytes, bytearray, memoryview)):
            raw = bytes(data)
            self._write(topic, stamp_of_cdr(raw), raw)
        else:
            self._write(topic, stamp_of_msg(data), self._cdr(topic, data))

    def _write_exchange(self, writer: SplitWriter, clock_ns: int | None,
                        inputs: dict[str, Any]) -> None:
        """/clock at ``clock_ns`` (None: not recorded), then every step topic's (stamp,
        message) pairs of one exchange in topic order, each topic's in stamp order: CDR bytes
        from DDS or message objects from the intra-process bus (where a load cell's record
        comes as a ``ForceSamples`` block, each of its readings as its own message, encoded at
        once). Through one ``SplitWriter.reserve_many`` where it allows (the same bytes; a dozen
        messages per servo exchange, a thousand in a 1 kHz record), else one ``write`` per
        message."""
        items: list[tuple[str, int, bytes]] = []
        if clock_ns is not None:
            items.append(('/clock', clock_ns, cdr.clock_cdr(clock_ns)))
        encoders = self._encoders
        for topic in self.step_order:
            pairs = inputs.get(topic)
            if not pairs:
                continue
            encode = encoders.get(topic)
            for t, msg in pairs:
                cls = msg.__class__
                if cls is ForceSamples:              # a block of readings: each its message
                    items += zip(itertools.repeat(topic), msg.stamps_ns, msg.cdr())
                    continue
                if encode is None:
                    encode = encoders[topic] = (
                        bytes if cls in (bytes, bytearray, memoryview)
                        else cdr.encoder(cls) or functools.partial(self._cdr, topic))
                items.append((topic, t, encode(msg)))
        if not items:
            return
        now = time.monotonic()
        if now >= self._next_flush:      # a SIGKILL loses at most this period of a lock-step run
            self._next_flush = now + self.flush_period_s
            writer.flush()
        put_many = writer.reserve_many(len(items))
        if put_many is not None:
            put_many(items)
            self.count += len(items)
            return
        n = 0
        try:
            for topic, t, data in items:
                writer.write(topic, t, data)
                n += 1
        except DiskFull as exc:
            self.count += n
            self._disk_full(exc)
            return
        self.count += n

    def _cdr(self, topic: str, msg: Any) -> bytes:
        """CDR of a message object as DDS puts it on the wire, from ``runtime.cdr``'s encoder of
        its class where there is one. Else rclpy's serialisation, which aligns for the elements
        of an empty sequence of 8-byte numbers even when it is the last field and nothing
        follows, and leaves the end of its buffer as it was; a reader wants at most 3 bytes of
        end padding. Such a message is cut at its true end (measured by the bag's typestore)
        and padded to 4 (``cdr.ends_padded`` names the same messages)."""
        enc = cdr.encoder(msg.__class__)
        if enc is not None:
            return enc(msg)
        raw = serialize_message(msg)
        rule = self._trim.get(topic)
        if rule is None:
            rule = self._trim[topic] = cdr.trim_rule(type(msg))
        if rule is cdr.TRIM_NEVER or (rule is not cdr.TRIM_ALWAYS and
                                      len(getattr(msg, rule)) > 0):
            return raw
        msgdef = self.store.get_msgdef(self.connections[topic])
        end, _ = msgdef.getsize_cdr_to_ros1(memoryview(raw)[4:], 0, None, 0, self.store)
        pad = -end % 4
        return raw[:2] + bytes((0, pad)) + raw[4:4 + end] + bytes(pad)

    def on_step(self, t_ns: int, dt_s: float, inputs: dict[str, Any]) -> None:
        """Write /clock and every step topic of the previous tick t_(k-1)."""
        if self.end_ns is not None:
            return
        prev = t_ns - round(dt_s * 1e9)
        if self.writer is not None:
            self._write_exchange(self.writer, prev if '/clock' in self.connections else None,
                                 inputs)
        if dt_s < 1e-6:
            self.end_ns = prev            # the clock's flush tick: nothing later is recorded

    def _end(self) -> dict[str, Any]:
        """How the run ended: the runner's end file; for a recorder started by hand (no
        runner), the last protocol status it recorded (done, aborted or cancelled, with the
        sequencer's reason); else interrupted."""
        now = datetime.datetime.now(datetime.UTC).isoformat(timespec='milliseconds')
        try:
            with open(self.end_file, encoding='utf-8') as fh:
                return dict(json.load(fh))
        except (OSError, ValueError):
            pass
        ended = {2: ('done', 0), 3: ('aborted', 4), 4: ('cancelled', 5)}
        if self.last_status is not None and self.last_status[0] in ended:
            state, code = ended[self.last_status[0]]
            return {'state': state, 'code': code, 'reason': self.last_status[1], 'end': now}
        why = ('the recorder stopped before the protocol ended' if self.last_status is not None
               else 'the recorder stopped before the run ended')
        return {'state': 'interrupted', 'code': None, 'reason': why, 'end': now}

    def close(self) -> None:
        """Close the bag (idempotent); on a wall clock print what was written per topic and
        the gaps in the publication sequence numbers (lost messages)."""
        if self.writer is not None:
            self.writer.set_custom_data(END_KEY, yaml.safe_dump(self._end(), sort_keys=False))
            self.writer.close()
            self.writer = None
            print(f'recorder: bag closed with {self.count} messages', flush=True)
            if not self.lockstep:
                for topic, n in sorted(self.written.items()):
                    gaps = sum(last - first + 1 - got for first, last, got
                               in self.sequence.get(topic, {}).values())
                    print(f'  {topic:34s} {n:8d} written, {gaps} lost in between', flush=True)

    def destroy_node(self) -> None:
        """Close the bag before the node goes."""
        self.close()
        super().destroy_node()


STATUS_TYPE = 'pam_bench_interfaces/msg/ProtocolStatus'
"""The sequencer's status: the recorder keeps the last it recorded (``Recorder._end``)."""


def status_of(data: bytes) -> tuple[int, str] | None:
    """(state, reason or phase) of a serialised ``ProtocolStatus`` (None when malformed)."""
    from pam_bench_interfaces.msg import ProtocolStatus
    from rclpy.serialization import deserialize_message
    try:
        msg = deserialize_message(bytes(data), ProtocolStatus)
    except Exception:  # noqa: BLE001 - a malformed message: nothing learnt, never fatal
        return None
    return int(msg.state), f'protocol {msg.protocol} ' + (msg.reason or msg.phase)


DIAGNOSTICS_TYPE = 'diagnostic_msgs/msg/DiagnosticArray'
"""The one recorded type many nodes publish on one topic: its losses are counted per node."""


def publisher_of(data: bytes) -> str:
    """The node a serialised ``DiagnosticArray`` comes from: its statuses are named
    ``NODE: concern`` (``runtime.diagnostics``; a driver of a lab's names its own); '?' when
    it names none."""
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.serialization import deserialize_message
    try:
        msg = deserialize_message(bytes(data), DiagnosticArray)
    except Exception:  # noqa: BLE001 - a malformed message: counted apart, never fatal
        return '?'
    names = [st.name.partition(':')[0].strip() for st in msg.status if ':' in st.name]
    return names[0] if names else (msg.status[0].hardware_id if msg.status else '?')


def record(out_dir: str, topic_names: list[str], record_all: bool, compress: bool = True,
           max_bytes: int | None = None, max_duration_s: float | None = None) -> int:
    """``pam-bench record``: record ``topic_names`` (or every topic, ``record_all``) on the
    wall clock into ``out_dir`` until Ctrl-C or SIGTERM; the bag is closed valid. ``compress``,
    ``max_bytes`` and ``max_duration_s`` are the recorder's settings of the same meaning (None:
    their defaults). Returns the exit code."""
    import rclpy
    from rclpy.parameter import Parameter

    from pam_bench.runtime.process import install_interrupt_handlers, lean_spin, serve_services
    install_interrupt_handlers()
    rclpy.init()
    node = None
    try:
        node = Recorder('recorder', parameter_overrides=[
            Parameter('lockstep', value=False), Parameter('out_dir', value=out_dir),
            Parameter('record_all', value=record_all), Parameter('compress', value=compress),
            *([Parameter('max_bag_size_bytes', value=int(max_bytes))]
              if max_bytes is not None else []),
            *([Parameter('max_bag_duration_s', value=float(max_duration_s))]
              if max_duration_s is not None else []),
            # an empty list of strings is [''] to ROS (runtime.params.ros_value)
            Parameter('topic_names', value=list(topic_names) or ['']),
            Parameter('event_topics', value=['/diagnostics:diagnostic_msgs/msg/'
                                             'DiagnosticArray'] if record_all else [''])])
        lean_spin(node, graceful=True, poll=serve_services(node))
    except KeyboardInterrupt:
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


def main(args: list[str] | None = None) -> None:
    """Run the node."""
    run_node(Recorder, args)


if __name__ == '__main__':
    main()
