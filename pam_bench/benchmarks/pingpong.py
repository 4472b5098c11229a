"""rclpy ping-pong between two processes: the floor under one lock-step exchange.

A ping node publishes a stamped message and waits for the pong node's echo before sending the
next; the rate of round trips per second is what one exchange step can at best reach (a step
is one /clock publication and one acknowledgement, a round trip).
"""

from __future__ import annotations

import subprocess
import sys
import time

__all__ = ['pingpong_rate', 'pong_main']


def pong_main() -> None:
    """Echo every /pp/ping on /pp/pong until shut down."""
    import rclpy
    from rclpy.executors import ExternalShutdownException
    from rosgraph_msgs.msg import Clock

    from pam_bench.nodes.base import RELIABLE

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

    from pam_bench.bringup.runner import ros_env
    from pam_bench.nodes.base import RELIABLE

    env = ros_env()
    proc = subprocess.Popen([sys.executable, '-c',
                             'from pam_bench.benchmarks.pingpong import pong_main; pong_main()'],
                            env=env)
    import os
    os.environ.update({k: env[k] for k in ('ROS_DOMAIN_ID', 'ROS_AUTOMATIC_DISCOVERY_RANGE')})
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
        proc.terminate()
        proc.wait(timeout=10)
    if not state['t1']:
        raise RuntimeError('ping-pong did not complete')
    return count / (state['t1'] - state['t0'])
