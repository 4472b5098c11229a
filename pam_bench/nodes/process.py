"""A node process: its main(), its signal handling, its start-up checks and the lean spin.

``run_node`` is every node's ``main()``: interrupt handlers installed whatever the process
inherited, the node built and checked (an unknown, mistyped or out-of-range parameter gives one
line and exit code 2), then spun (``lean_spin`` for nodes with subscriptions only) until Ctrl-C,
SIGTERM or an external shutdown, and cleaned up.
"""

from __future__ import annotations

import signal
from collections.abc import Callable
from typing import Any

import rclpy
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from pam_bench.models.errors import ModelError
from pam_bench.models.params import check_known
from pam_bench.nodes.profiling import profiled

__all__ = ['lean_spin', 'reject_undeclared', 'install_interrupt_handlers', 'fail_line',
           'start_node', 'run_node']


def lean_spin(node: Node, graceful: bool = False) -> None:
    """Spin a node that has only subscriptions, cheaper than rclpy's executor.

    One wait set over the node's subscriptions and the signal guard condition; at every wake-up
    every ready subscription is drained. rclpy's SingleThreadedExecutor rebuilds its wait set
    and schedules a task per callback, which dominates the cost of a lock-step exchange.
    A node may define ``lean_poll()``: it is called after every wake-up and at least every
    50 ms (the place for what timers would do). Returns when the context shuts down; SIGINT or
    SIGTERM raise KeyboardInterrupt. With ``graceful`` they only set a flag that the loop reads
    between messages, so a callback (a bag write) is never cut in the middle, and it returns.
    """
    import signal as _signal

    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
    from rclpy.signals import SignalHandlerGuardCondition

    ctx = node.context
    subs = list(node.subscriptions)
    by_ptr = {s.handle.pointer: s for s in subs}
    guard = SignalHandlerGuardCondition(context=ctx)
    wait_set = _rclpy.WaitSet(len(subs), 1, 0, 0, 0, 0, ctx.handle)
    poll = getattr(node, 'lean_poll', None)
    stop = []
    if graceful:
        for sig in (_signal.SIGINT, _signal.SIGTERM):
            _signal.signal(sig, lambda *_: stop.append(True))
    try:
        while ctx.ok() and not stop:
            wait_set.clear_entities()
            for sub in subs:
                wait_set.add_subscription(sub.handle)
            wait_set.add_guard_condition(guard.handle)
            wait_set.wait(50_000_000)
            if guard.handle.pointer in wait_set.get_ready_entities('guard_condition'):
                raise KeyboardInterrupt
            for ptr in wait_set.get_ready_entities('subscription'):
                sub = by_ptr[ptr]
                while not stop:
                    taken = sub.handle.take_message(sub.msg_type, sub.raw)
                    if taken is None:
                        break
                    sub.callback(taken[0])
            if poll is not None:
                poll()
    finally:
        guard.destroy()


def reject_undeclared(node: Node, overrides: list[Any] | None = None) -> None:
    """Stop a node given a parameter it does not declare (a misspelt key in a params file or a
    scene would otherwise be ignored and the default used).

    Args:
        node: a node after its constructor declared every parameter.
        overrides: the ``Parameter`` overrides it was built with (default: those rclpy
            resolved for it from ``--params-file`` and ``-p``).

    Raises:
        ParameterError: names the unknown key and the nearest declared one.
    """
    names = ([p.name for p in overrides] if overrides is not None
             else list(getattr(node, '_parameter_overrides', {})))
    declared = node.list_parameters([], 0).names
    check_known(names, declared, f'node {node.get_name()}: parameters')


def install_interrupt_handlers() -> None:
    """SIGINT and SIGTERM raise KeyboardInterrupt, whatever the process inherited: a process
    started in the background by a non-interactive shell inherits SIGINT ignored, and Python
    then installs no handler of its own."""
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, signal.default_int_handler)


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
    """Build a node and refuse undeclared parameters; on a bad parameter print one line
    (``fail_line``) and return None."""
    import sys
    try:
        node = cls()
        reject_undeclared(node)
    except (ModelError, ParameterException) as exc:
        print(fail_line(name, exc), file=sys.stderr, flush=True)
        return None
    return node


def run_node(cls: type[Node], args: list[str] | None = None) -> None:
    """The Jazzy ``main()``: init, spin, stop on Ctrl-C or external shutdown, clean up.

    A node that cannot start (a bad, misspelt or out-of-range parameter) prints one line naming
    the key and exits with code 2, no traceback. Nodes with only subscriptions
    (``LEAN_SPIN``) use ``lean_spin`` unless ``PAM_BENCH_EXECUTOR=single`` asks for rclpy's
    SingleThreadedExecutor.
    """
    import os
    import sys
    install_interrupt_handlers()
    rclpy.init(args=args)
    node = None
    code = 0
    try:
        node = start_node(cls, _node_name(cls, args))
        if node is None:
            code = 2
            return
        with profiled(node.get_name()):
            if getattr(node, 'LEAN_SPIN', False) and \
                    os.environ.get('PAM_BENCH_EXECUTOR') != 'single':
                lean_spin(node, graceful=getattr(node, 'GRACEFUL_STOP', False))
            else:
                rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
        if code:
            sys.exit(code)
