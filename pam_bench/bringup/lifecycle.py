"""The wall-clock bring-up's lifecycle manager: configure, then activate, the managed nodes.

A wall-clock run starts its devices (or drivers) and its torque servo with ``managed: true``
(``runtime.lifecycle``): they come up unconfigured and publish nothing until this manager,
in the process that runs the scene, has taken each through ``configure`` and ``activate``
over its ``~/change_state`` service, in the order given (the devices first, then the servo),
as nav2's lifecycle manager or a ros2_control controller manager does. A node whose process
has gone, whose service does not come within ``timeout_s``, or whose transition fails stops
the bring-up with one line naming it.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Sequence

from pam_bench.bringup.errors import LayoutError

__all__ = ['activate_nodes', 'TRANSITIONS']

TRANSITIONS = ('configure', 'activate')
"""The transitions the bring-up drives, in order."""


def activate_nodes(names: Sequence[str], namespace: str, domain_id: int,
                   gone: Callable[[str], bool], timeout_s: float = 60.0) -> float:
    """Configure, then activate, each node of ``names`` (in ``namespace``) on ``domain_id``.

    Args:
        names: the managed nodes, in the order to bring them up.
        namespace: their ROS namespace ('': the root).
        domain_id: the run's ROS domain.
        gone: whether a node's process has ended (its service will never come).
        timeout_s: the most to wait for a node's service (s).

    Returns:
        The time it took (s).

    Raises:
        LayoutError: a node gone, its service not there within ``timeout_s``, or a transition
            refused (one line naming the node and the transition).
    """
    import rclpy
    from lifecycle_msgs.msg import Transition
    from lifecycle_msgs.srv import ChangeState
    from rclpy.executors import SingleThreadedExecutor

    t0 = time.monotonic()
    ids = {'configure': Transition.TRANSITION_CONFIGURE,
           'activate': Transition.TRANSITION_ACTIVATE}
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain_id)
    try:
        node = rclpy.create_node('pam_bench_lifecycle_manager', context=context,
                                 start_parameter_services=False)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        prefix = '/' + namespace.strip('/') if namespace.strip('/') else ''
        clients = {n: node.create_client(ChangeState, f'{prefix}/{n}/change_state')
                   for n in names}
        for name in names:
            client = clients[name]
            end = time.monotonic() + timeout_s
            while not client.service_is_ready():
                if gone(name):
                    raise LayoutError(f'{name}: its process ended before it was configured')
                if time.monotonic() > end:
                    raise LayoutError(f'{name}: no lifecycle service {client.srv_name} within '
                                      f'{timeout_s:g} s')
                executor.spin_once(timeout_sec=0.05)
            for step in TRANSITIONS:
                request = ChangeState.Request()
                request.transition.id = ids[step]
                future = client.call_async(request)
                end = time.monotonic() + timeout_s
                while not future.done():
                    if gone(name) or time.monotonic() > end:
                        raise LayoutError(f'{name}: no answer to {step}')
                    executor.spin_once(timeout_sec=0.05)
                result = future.result()
                if result is None or not result.success:
                    raise LayoutError(f'{name}: {step} refused (its diagnostics say why)')
        executor.shutdown()
        node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)
    return time.monotonic() - t0
