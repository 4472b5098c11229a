"""A lock-step run with every node composed in one process on the intra-process bus
(``runtime.intra``): separate ROS 2 nodes, as in rclcpp component composition, with no DDS
between them."""

from __future__ import annotations

import os
import sys
import time
from typing import Any

from pam_bench.bringup.common import RunResult, result_of, ros_env, write_end_state
from pam_bench.config.nodes import NODES
from pam_bench.config.scene import Scene

__all__ = ['run_composed', 'clock_done']


def clock_done(nodes: list[Any], scene: Scene) -> bool:
    """In one process: whether the sim clock ended the run (it has its summary)."""
    clock = nodes[-1] if nodes and len(nodes) == len(scene.nodes) + 1 else None
    return getattr(clock, 'summary', None) is not None


def run_composed(scene: Scene, settings: dict[str, Any], domain_id: int | None,
                    quiet: bool) -> RunResult:
    """Run the scene composed in this process (module docstring). The clock starts at once
    when every node is ready: its grace for late DDS matches is for nodes in other processes,
    and here there are none."""
    import contextlib
    import dataclasses
    import importlib
    import io

    import rclpy
    from rclpy.exceptions import ParameterException
    from rclpy.executors import SingleThreadedExecutor

    from pam_bench.runtime import intra
    from pam_bench.runtime.params import overrides_of
    from pam_bench.runtime.process import fail_line, reject_undeclared
    from pam_bench.runtime.profiling import profiled
    from pam_bench.vocabulary.errors import ParameterError

    env = ros_env(domain_id)
    os.environ['ROS_DOMAIN_ID'] = env['ROS_DOMAIN_ID']
    os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    context = rclpy.Context()
    rclpy.init(context=context)
    executor = SingleThreadedExecutor(context=context)
    nodes = []
    code = 0
    buf = io.StringIO()
    t0 = time.monotonic()
    bus = intra.IntraProcessBus()
    try:
        for name in ['recorder'] * ('recorder' in scene.nodes) + [
                n for n in scene.nodes if n != 'recorder'] + ['sim_clock']:
            t = NODES[name]
            cls = getattr(importlib.import_module(t.module), t.cls)
            st = settings[name]
            if name == 'sim_clock':
                st = dataclasses.replace(st, grace_s=0.0)
            overrides = overrides_of(st)
            extra = {'lean': True} if name == 'sim_clock' else {}    # polled by the loop
            try:
                node = cls(name, context=context, parameter_overrides=overrides, bus=bus,
                           **extra)
            except ParameterException as exc:
                raise ParameterError(fail_line(name, exc)) from None
            nodes.append(node)
            reject_undeclared(node, overrides)
            executor.add_node(node)
        with contextlib.redirect_stdout(buf if quiet else sys.stdout):
            try:
                with profiled('composed'):
                    intra.spin_composed(bus, nodes, executor)
            except SystemExit as exc:
                code = int(exc.code or 0)
    finally:
        write_end_state(settings, code if code or clock_done(nodes, scene) else None)
        clock = nodes[-1] if nodes and len(nodes) == len(scene.nodes) + 1 else None
        for node in nodes:
            executor.remove_node(node)
            node.destroy_node()
        executor.shutdown()
        rclpy.try_shutdown(context=context)
    summary = getattr(clock, 'summary', None)
    if summary is None:                 # interrupted before the clock finished
        wall = time.monotonic() - t0
        k = getattr(clock, 'k', 0)
        return RunResult(code, k, k * getattr(clock, 'step_s', 0.0), wall, k / wall)
    res = result_of(summary, code)
    res.stats['deliveries'] = bus.deliveries      # what separate processes would send by DDS
    return res
