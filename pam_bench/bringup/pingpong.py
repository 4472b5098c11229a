"""rclpy ping-pong between two processes: the floor under one lock-step exchange.

A ping node publishes a stamped message and waits for the pong node's echo before sending the
next; the rate of round trips per second is what one exchange step can at best reach (a step
is one /clock publication and one acknowledgement, a round trip). The fan-out is the same with
N echoing processes at once, spinning as the nodes do: the floor of a lock-step exchange with N
separate-process participants that do no work, before any message of their own.
"""

from __future__ import annotations

import subprocess
import sys
import time

__all__ = ['pingpong_rate', 'pong_main', 'fanout_rate', 'fanout_echo_main']


def _start_helpers(main: str, count: int) -> list[subprocess.Popen]:
    """``count`` processes running this module's ``main`` on the run's ROS environment
    (``ros_env``: loopback discovery, a private domain), which this process joins too."""
    import os

    from pam_bench.bringup.runner import ros_env

    env = ros_env()
    procs = [subprocess.Popen([sys.executable, '-c', f'from pam_bench.bringup.pingpong '
                               f'import {main}; {main}()'], env=env) for _ in range(count)]
    os.environ.update({k: env[k] for k in ('ROS_DOMAIN_ID', 'ROS_AUTOMATIC_DISCOVERY_RANGE')})
    return procs


def _stop(procs: list[subprocess.Popen], timeout_s: float = 10.0) -> None:
    """Terminate the helpers and wait for them; kill one that is still there after
    ``timeout_s``. A fan-out helper once hung in its teardown, inside Fast DDS's
    ``destroy_participant`` (spinning in ``DomainParticipant::set_listener``, where no signal
    handler runs), and kept a core busy through the rest of a `pam-bench bench` run. Never
    raises: it runs in a ``finally`` and must not hide the study's own error."""
    for p in procs:
        if p.poll() is None:
            p.terminate()
    deadline = time.monotonic() + timeout_s
    for p in procs:
        try:
            p.wait(timeout=max(deadline - time.monotonic(), 0.0))
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


def pong_main() -> None:
    """Echo every /pp/ping on /pp/pong until shut down."""
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from rosgraph_msgs.msg import Clock

    from pam_bench.runtime.base import RELIABLE

    rclpy.init()
    node = rclpy.create_node('pong')
    pub = node.create_publisher(Clock, '/pp/pong', RELIABLE)
    node.create_subscription(Clock, '/pp/ping', pub.publish, RELIABLE)
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


def pingpong_rate(count: int = 2000, warmup: int = 100) -> float:
    """Round trips per second over ``count`` exchanges with a pong in another process."""
    import rclpy
    from rosgraph_msgs.msg import Clock

    from pam_bench.runtime.base import RELIABLE

    proc, = _start_helpers('pong_main', 1)
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = rclpy.create_node('ping', context=ctx)
    state = {'n': 0, 't0': 0.0, 't1': 0.0}
    pub = node.create_publisher(Clock, '/pp/ping', RELIABLE)

    def on_pong(msg: Clock) -> None:
        state['n'] += 1
        if state['n'] == warmup:
            state['t0'] = time.perf_counter()
        if state['n'] == warmup + count:
            state['t1'] = time.perf_counter()
            return
        pub.publish(msg)

    node.create_subscription(Clock, '/pp/pong', on_pong, RELIABLE)
    from rclpy.executors import SingleThreadedExecutor
    ex = SingleThreadedExecutor(context=ctx)
    ex.add_node(node)
    try:
        deadline = time.monotonic() + 30.0
        while node.count_subscribers('/pp/ping') == 0 or node.count_publishers('/pp/pong') == 0:
            ex.spin_once(timeout_sec=0.05)
            if time.monotonic() > deadline:
                raise RuntimeError('pong process never came up')
        time.sleep(0.3)
        pub.publish(Clock())
        while not state['t1'] and time.monotonic() < deadline + 60:
            ex.spin_once(timeout_sec=0.5)
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)
        _stop([proc])
    if not state['t1']:
        raise RuntimeError('ping-pong did not complete')
    return count / (state['t1'] - state['t0'])


class _Done(Exception):
    """The fan-out measurement has its count."""


def fanout_echo_main() -> None:
    """Acknowledge every /ff/tick on /ff/ack with its stamp (a participant doing no work),
    spinning as the lock-step nodes do (``lean_spin``)."""
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from rosgraph_msgs.msg import Clock

    from pam_bench.runtime.base import LOCKSTEP
    from pam_bench.runtime.process import install_interrupt_handlers, lean_spin

    install_interrupt_handlers()
    rclpy.init()
    node = rclpy.create_node('fanout_echo')
    pub = node.create_publisher(Clock, '/ff/ack', LOCKSTEP)
    node.create_subscription(Clock, '/ff/tick', pub.publish, LOCKSTEP)
    try:
        lean_spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


def fanout_rate(participants: int, count: int = 1000, warmup: int = 50) -> float:
    """Exchanges per second of a lock-step with no work: this process publishes a tick, each
    of ``participants`` processes acknowledges it, the next tick goes out when all have; the
    floor under a lock-step exchange with that many separate-process participants.

    Raises:
        RuntimeError: the participants never came up or the count was not reached.
    """
    import rclpy
    from rosgraph_msgs.msg import Clock

    from pam_bench.runtime.base import LOCKSTEP
    from pam_bench.runtime.process import lean_spin

    procs = _start_helpers('fanout_echo_main', participants)
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = rclpy.create_node('fanout_clock', context=ctx)
    pub = node.create_publisher(Clock, '/ff/tick', LOCKSTEP)
    state = {'k': 0, 'acks': 0, 't0': 0.0, 't1': 0.0}

    def tick() -> None:
        msg = Clock()
        msg.clock.sec = state['k']
        pub.publish(msg)

    def on_ack(msg: Clock) -> None:
        if msg.clock.sec != state['k']:
            return
        state['acks'] += 1
        if state['acks'] < participants:
            return
        state['acks'] = 0
        state['k'] += 1
        if state['k'] == warmup:
            state['t0'] = time.perf_counter()
        if state['k'] == warmup + count:
            state['t1'] = time.perf_counter()
            raise _Done
        tick()

    node.create_subscription(Clock, '/ff/ack', on_ack, LOCKSTEP)
    try:
        deadline = time.monotonic() + 30.0 + 2.0 * participants
        while node.count_subscribers('/ff/tick') < participants or \
                node.count_publishers('/ff/ack') < participants:
            time.sleep(0.05)
            if time.monotonic() > deadline:
                raise RuntimeError('fan-out participants never came up')
        time.sleep(0.5)
        end = time.monotonic() + 60.0 + count / 50.0

        def overdue() -> None:
            if time.monotonic() > end:
                raise RuntimeError(f'fan-out stalled at exchange {state["k"]}')

        tick()
        try:
            lean_spin(node, poll=overdue)
        except _Done:
            pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)
        _stop(procs)
    if not state['t1']:
        raise RuntimeError('fan-out did not complete')
    return count / (state['t1'] - state['t0'])
