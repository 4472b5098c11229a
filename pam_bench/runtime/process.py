"""A node process: its main(), its signal handling, its start-up checks and the lean spin.

``run_node`` is every node's ``main()``: interrupt handlers installed whatever the process
inherited, the node built and checked (an unknown, mistyped or out-of-range parameter gives one
line and exit code 2), then spun (``lean_spin`` for nodes with subscriptions only,
``deadline_spin`` for a node ticking on a wall clock) until Ctrl-C, SIGTERM or an external
shutdown, and cleaned up.
"""

from __future__ import annotations

import gc
import os
import signal
import time
from collections.abc import Callable
from typing import Any

import rclpy
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from pam_bench.runtime.leaving import leave
from pam_bench.runtime.params import wildcard_only_keys
from pam_bench.runtime.profiling import profiled
from pam_bench.runtime.scheduling import set_realtime_priority
from pam_bench.vocabulary.errors import PamBenchError
from pam_bench.vocabulary.params import check_known

__all__ = ['lean_spin', 'deadline_spin', 'spin', 'serve_services', 'reject_undeclared',
           'install_interrupt_handlers', 'ignore_interrupts', 'interrupt_guard', 'fail_line',
           'start_node', 'run_node']


_GUARDS: dict[Any, Any] = {}
"""Context -> its signal guard condition (``interrupt_guard``)."""


def interrupt_guard(context: Any) -> Any:
    """The guard condition that wakes a wait set of ``context`` on SIGINT or SIGTERM: one per
    context, kept as long as the process lives.

    rclpy triggers its signal guard conditions from a thread of its own, woken by the signal,
    that walks their list without a lock; the main thread meanwhile gets the signal's
    KeyboardInterrupt at once. A guard destroyed on the way out (a spin's ``finally``) was
    then triggered after it was freed: a node interrupted while it waited for /clock ended by
    SIGSEGV in about half of the tries (``test_process``). Kept for the process's life, the
    guard is never freed while that thread may hold it.
    """
    from rclpy.signals import SignalHandlerGuardCondition
    if context not in _GUARDS:
        _GUARDS[context] = SignalHandlerGuardCondition(context=context)
    return _GUARDS[context]


def serve_services(node: Node) -> Callable[[], None]:
    """A poll that answers ``node``'s pending service requests (parameter services) without
    blocking and without an executor, so the lean loops below keep their subscriptions to
    themselves."""

    def serve() -> None:
        for srv in node.services:
            while True:
                srv_type: Any = srv.srv_type
                request, header = srv.handle.service_take_request(srv_type.Request)
                if header is None:
                    break
                srv.send_response(srv.callback(request, srv_type.Response()), header)

    return serve


def deadline_spin(nodes: list[Node], tick: Callable[[], None], period_s: float,
                  poll: Callable[[], None] | None = None, poll_period_s: float = 0.005,
                  should_stop: Callable[[], bool] | None = None) -> None:
    """Call ``tick`` every ``period_s`` on a monotonic deadline and serve the nodes'
    subscriptions in between (one wait set, as ``lean_spin``).

    The loop sleeps in the wait set until the next deadline or message; a message is handled
    at once. A tick that ends late keeps the phase (the next deadline is one period after the
    missed one); a loop more than a period behind drops the ticks it missed, as a driver's
    control loop does, serves the messages that came meanwhile without waiting, and ticks
    again at once (a tick longer than the period, a Modbus round trip on a loaded machine, once
    starved the subscriptions: commands reached the driver in bursts seconds apart; waiting a
    whole period after such a tick cost a 1 kHz driver a tenth of its rate). A loop that wakes
    more than a period past its deadline (the process stalled while it waited) serves the
    messages that came meanwhile before it ticks too: a tick first would judge the inputs by
    their state before the stall (on a loaded machine a sequencer aborted on an encoder 0.53 s
    'stale' while the recorder had the encoder's messages without a gap). ``poll``
    (services, a bus refresh) runs every ``poll_period_s``. Returns when ``should_stop()`` is
    true after a tick. SIGINT and SIGTERM end the loop between ticks, never inside one (a tick
    cut between its publishes would leave a device's outputs half sent), and then raise
    KeyboardInterrupt. rclpy's timer against
    this loop: ``BENCHMARKS.md``, "The bench on a wall clock".
    """
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy

    ctx = nodes[0].context
    subs = [s for n in nodes for s in n.subscriptions]
    by_ptr = {s.handle.pointer: s for s in subs}
    guard = interrupt_guard(ctx)
    wait_set = _rclpy.WaitSet(len(subs), 1, 0, 0, 0, 0, ctx.handle)
    period = max(round(period_s * 1e9), 1)
    poll_period = round(poll_period_s * 1e9)
    # Everything built so far (modules, nodes, models) is long-lived: move it out of the
    # collector's generations so that a full collection walks only what the loop allocates
    # (a full collection over the start-up heap stalled a 1 kHz loop by tens of ms).
    gc.collect()
    gc.freeze()
    now = time.monotonic_ns()
    deadline, next_poll = now + period, now + poll_period
    stop: list[int] = []
    serve_first = served = False
    previous = {sig: signal.signal(sig, lambda signum, _: stop.append(signum))
                for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        while ctx.ok() and not stop:
            now = time.monotonic_ns()
            if now - deadline >= period and not served:   # woke a period late (the process
                serve_first = served = True                # stalled): the messages first
            if now >= deadline and not serve_first:
                served = False
                tick()
                if should_stop is not None and should_stop():
                    return
                deadline += period
                after = time.monotonic_ns()
                if deadline <= after:       # more than a period behind: the ticks missed are
                    deadline = after        # dropped, the messages served, then a tick at once
                    serve_first = True
                continue
            if poll is not None and now >= next_poll and not serve_first:
                poll()
                next_poll = now + poll_period
                continue
            wait_set.clear_entities()
            for sub in subs:
                wait_set.add_subscription(sub.handle)
            wait_set.add_guard_condition(guard.handle)
            wake = deadline if poll is None else min(deadline, next_poll)
            wait_set.wait(0 if serve_first else max(wake - now, 0))
            serve_first = False
            if guard.handle.pointer in wait_set.get_ready_entities('guard_condition'):
                break
            for ptr in wait_set.get_ready_entities('subscription'):
                sub = by_ptr[ptr]
                while True:
                    taken = sub.handle.take_message(sub.msg_type, sub.raw)
                    if taken is None:
                        break
                    sub.callback(taken[0])
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    if stop or not ctx.ok() or should_stop is None or not should_stop():
        raise KeyboardInterrupt


def lean_spin(node: Node, graceful: bool = False,
              poll: Callable[[], None] | None = None) -> None:
    """Spin a node that has only subscriptions, cheaper than rclpy's executor.

    One wait set over the node's subscriptions and the signal guard condition; at every wake-up
    every ready subscription is drained. rclpy's SingleThreadedExecutor rebuilds its wait set
    and schedules a task per callback, which dominates the cost of a lock-step exchange.
    A node may define ``lean_poll()``: it is called after every wake-up and at least every
    50 ms (the place for what timers would do), as is ``poll`` (services: ``serve_services``).
    A subscription whose callback has ``with_info`` set gets ``(message, info)``: the
    message info of the middleware (receive time, publication sequence number). A node that
    creates or destroys subscriptions while it spins bumps ``subscriptions_version``.
    Returns when the context shuts down; SIGINT or SIGTERM raise KeyboardInterrupt. With
    ``graceful`` they only set a flag that the loop reads between messages, so a callback (a
    bag write) is never cut in the middle, and it returns.
    """
    import signal as _signal

    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy

    ctx = node.context
    subs = list(node.subscriptions)
    by_ptr = {s.handle.pointer: s for s in subs}
    guard = interrupt_guard(ctx)
    wait_set = _rclpy.WaitSet(len(subs), 1, 0, 0, 0, 0, ctx.handle)
    polls = [p for p in (getattr(node, 'lean_poll', None), poll) if p is not None]
    with_info = {s.handle.pointer for s in subs if getattr(s.callback, 'with_info', False)}
    version = getattr(node, 'subscriptions_version', 0)
    stop = []
    if graceful:
        for sig in (_signal.SIGINT, _signal.SIGTERM):
            _signal.signal(sig, lambda *_: stop.append(True))
    while ctx.ok() and not stop:
        if getattr(node, 'subscriptions_version', 0) != version:   # came or went
            version = getattr(node, 'subscriptions_version', 0)
            subs = list(node.subscriptions)
            by_ptr = {s.handle.pointer: s for s in subs}
            with_info = {s.handle.pointer for s in subs
                         if getattr(s.callback, 'with_info', False)}
            wait_set = _rclpy.WaitSet(len(subs), 1, 0, 0, 0, 0, ctx.handle)
        wait_set.clear_entities()
        for sub in subs:
            wait_set.add_subscription(sub.handle)
        wait_set.add_guard_condition(guard.handle)
        wait_set.wait(50_000_000)
        if guard.handle.pointer in wait_set.get_ready_entities('guard_condition'):
            raise KeyboardInterrupt
        for ptr in wait_set.get_ready_entities('subscription'):
            sub = by_ptr[ptr]
            info = ptr in with_info
            while not stop:
                taken = sub.handle.take_message(sub.msg_type, sub.raw)
                if taken is None:
                    break
                if info:
                    sub.callback(taken[0], taken[1])
                else:
                    sub.callback(taken[0])
        for p in polls:
            p()
    if stop:
        _drain(subs, wait_set, with_info)


def _drain(subs: list[Any], wait_set: Any, with_info: set[int], quiet_s: float = 0.05,
           limit_s: float = 1.0) -> None:
    """After a graceful stop: take what is still in flight until nothing came for
    ``quiet_s`` (at most ``limit_s``), so the last messages a publisher sent before it
    stopped are not lost."""
    end = time.monotonic() + limit_s
    by_ptr = {s.handle.pointer: s for s in subs}
    while time.monotonic() < end:
        wait_set.clear_entities()
        for sub in subs:
            wait_set.add_subscription(sub.handle)
        wait_set.wait(round(quiet_s * 1e9))
        ready = wait_set.get_ready_entities('subscription')
        if not ready:
            return
        for ptr in ready:
            sub = by_ptr[ptr]
            while True:
                taken = sub.handle.take_message(sub.msg_type, sub.raw)
                if taken is None:
                    break
                if ptr in with_info:
                    sub.callback(taken[0], taken[1])
                else:
                    sub.callback(taken[0])


def reject_undeclared(node: Node, overrides: list[Any] | None = None,
                      args: list[str] | None = None) -> None:
    """Stop a node given a parameter it does not declare (a misspelt key in a params file or a
    scene would otherwise be ignored and the default used). A key that reaches it only through
    a wildcard section (``/**:``, shared by several nodes) is ignored with a warning.

    Args:
        node: a node after its constructor declared every parameter.
        overrides: the ``Parameter`` overrides it was built with (default: those rclpy
            resolved for it from ``--params-file`` and ``-p``).
        args: the arguments rclpy was given (default ``sys.argv``): where the params files
            are, to tell a wildcard section's keys.

    Raises:
        ParameterError: names the unknown key and the nearest declared one.
    """
    import sys
    names = ([p.name for p in overrides] if overrides is not None
             else list(getattr(node, '_parameter_overrides', {})))
    declared = node.list_parameters([], 0).names
    wild = wildcard_only_keys(sys.argv if args is None else args) if overrides is None \
        else set()
    check_known([n for n in names if n not in wild], declared,
                f'node {node.get_name()}: parameters')
    ignored = sorted(n for n in names if n in wild and n not in declared)
    if ignored:
        node.get_logger().warning(f'a wildcard section of the params file sets '
                                  f'{", ".join(ignored)}, which this node does not have: '
                                  'ignored')


def install_interrupt_handlers() -> None:
    """SIGINT and SIGTERM raise KeyboardInterrupt, whatever the process inherited: a process
    started in the background by a non-interactive shell inherits SIGINT ignored, and Python
    then installs no handler of its own."""
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, signal.default_int_handler)


def ignore_interrupts() -> None:
    """From now on SIGINT and SIGTERM do nothing: a process whose stop is under way cleans up
    (bounded) and leaves; a second Ctrl-C would cut the clean-up with a traceback."""
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, signal.SIG_IGN)


def fail_line(name: str, exc: BaseException) -> str:
    """The one line a node prints when it cannot start (``bringup.runner.node_error``)."""
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return f'{name}: error: {text}'


def _node_name(cls: type, args: list[str] | None) -> str:
    import sys
    for a in (args if args is not None else sys.argv):
        if a.startswith('__node:='):
            return a.split(':=', 1)[1]
    return cls.__name__


def start_node(cls: Callable[[], Node], name: str) -> Any:
    """Build a node and refuse undeclared parameters; on a bad parameter, or a file or disk it
    cannot use (a recorder's bag), print one line (``fail_line``) and return None."""
    import sys
    try:
        node = cls()
        reject_undeclared(node)
    except (PamBenchError, ParameterException) as exc:
        print(fail_line(name, exc), file=sys.stderr, flush=True)
        return None
    except OSError as exc:              # a file or disk it needs: a recorder's bag folder
        text = exc.strerror if exc.strerror and not exc.filename else str(exc)
        print(f'{name}: error: {text}', file=sys.stderr, flush=True)
        return None
    return node


def spin(node: Any) -> int:
    """Spin ``node`` the way it declares (``spin_mode``) until it is done or interrupted;
    returns its exit code. ``PAM_BENCH_EXECUTOR=single`` puts every node on rclpy's
    SingleThreadedExecutor (to compare)."""
    from pam_bench.runtime.core import Spin
    mode = node.spin_mode()
    if os.environ.get('PAM_BENCH_EXECUTOR') == 'single':
        mode = Spin.EXECUTOR
    services = serve_services(node) if list(node.services) else None
    if mode == Spin.DEADLINE:
        priority = getattr(node.settings, 'realtime_priority', 0)
        if priority:
            node.get_logger().info(f'control loop: {set_realtime_priority(priority)}')
        deadline_spin([node], node.wall_tick, node.take_wall_ticks(),
                      serve_services(node), should_stop=lambda: node.exit_code is not None)
        return int(node.exit_code or 0)
    if mode == Spin.LEAN:
        lean_spin(node, graceful=node.GRACEFUL_STOP, poll=services)
        return 0
    from rclpy.executors import SingleThreadedExecutor
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    while node.context.ok() and node.exit_code is None:
        executor.spin_once(timeout_sec=0.1)
    return int(node.exit_code or 0)


def _own_args(argv: list[str]) -> list[str]:
    """The arguments before ``--ros-args`` (the program's name left out): a node takes none
    but ``-h``/``--help``; everything it is told goes through ``--ros-args``."""
    rest = list(argv[1:])
    return rest[:rest.index('--ros-args')] if '--ros-args' in rest else rest


def node_help(cls: type) -> str:
    """What ``NODE --help`` prints: what the node is, how to start it, and its parameters
    with unit, default and range (its settings class, the one owner of each)."""
    import sys

    from pam_bench.vocabulary.params import describe, flat_infos
    module = sys.modules.get(cls.__module__)
    doc = ((module.__doc__ if module is not None else '') or cls.__doc__ or
           '').strip().splitlines()
    name = cls.__module__.rsplit('.', 1)[-1]
    lines = [f'usage: {name} [-h] [--ros-args [-r __node:=NAME] [-r __ns:=NS] '
             '[--params-file FILE] [-p NAME:=VALUE ...]]', '',
             doc[0] if doc else name, '',
             'A ROS 2 node of pam_bench: everything it is told goes through --ros-args (see '
             'docs/drivers.md and README, "Node by node").', '', 'parameters:']
    settings = getattr(cls, 'SETTINGS', None)
    for info in flat_infos(settings) if settings is not None else []:
        lines.append(f'  {info.name} = {info.default!r}: {describe(info)}')
    return '\n'.join(lines)


def _answer(cls: type, own: list[str]) -> int:
    """Answer ``-h``/``--help`` (exit 0), or refuse any other argument before ``--ros-args``
    in one line (exit 2): a lab's ``valve_sim --params-file x`` would otherwise start the
    node without its file."""
    import sys
    if own[0] in ('-h', '--help'):
        print(node_help(cls))
        return 0
    name = cls.__module__.rsplit('.', 1)[-1]
    print(f'{name}: error: unknown argument {own[0]!r}: a node takes its settings after '
          f'--ros-args (-p NAME:=VALUE, --params-file FILE); {name} --help lists them',
          file=sys.stderr)
    return 2


def run_node(cls: type[Node], args: list[str] | None = None) -> None:
    """The Jazzy ``main()``: init, spin, stop on Ctrl-C or external shutdown, clean up.

    A node that cannot start (a bad, misspelt or out-of-range parameter) prints one line naming
    the key and exits with code 2, no traceback. The node says how it spins (``spin``). A
    callback may end the process with ``SystemExit`` (the sim clock at the end of a run);
    Ctrl-C or SIGTERM end it with the node's ``INTERRUPTED_CODE``, also while rclpy starts,
    and a second one during the clean-up is ignored (the clean-up is bounded: ``ACK_WAIT_S``).
    """
    import faulthandler
    import sys
    own = _own_args(sys.argv if args is None else args)
    if own:
        sys.exit(_answer(cls, own))
    faulthandler.enable()       # a crash in native code (DDS, numba) prints every thread's stack
    install_interrupt_handlers()
    try:
        rclpy.init(args=args)
    except KeyboardInterrupt:
        leave(getattr(cls, 'INTERRUPTED_CODE', 0))
    node: Any = None
    code = 0
    try:
        node = start_node(cls, _node_name(cls, args))
        if node is None:
            code = 2
            return
        with profiled(node.get_name()):
            code = spin(node)
    except SystemExit as exc:
        code = int(exc.code or 0)
    except KeyboardInterrupt:
        code = getattr(node, 'INTERRUPTED_CODE', 0)
    except ExternalShutdownException:
        pass
    except Exception:  # noqa: BLE001 - unexpected: its traceback and exit 1, as Python's own
        if rclpy.ok():
            import traceback
            traceback.print_exc()
            code = 1
        else:           # the run stopped this process while it started: a stop, not a fault
            code = getattr(cls, 'INTERRUPTED_CODE', 0)
    finally:
        ignore_interrupts()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
        leave(code)       # skips the DDS library's destructors (runtime.leaving)

