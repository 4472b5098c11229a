"""The device emulator: the simulated devices of a scene composed in one process on a wall clock.

Beside real drivers the sequencer, the torque servo and the recorder run in their own
processes; on 2 cores five device processes ticking at 1 kHz each would compete with them for
the CPU. The emulator builds the device nodes (separate ``Node`` objects with their own
parameters and parameter services) on one intra-process bus and ticks them on one monotonic
deadline in the chain order valve -> muscle -> loading servo -> load cell -> encoder, each at
its own ``rate_hz``: every device steps on what the one before it published in the same tick,
as the physics of one bench is one system. A loop that wakes late runs the ticks it missed at
their own stamps (``CATCH_UP_TICKS``), so the contract's 1 kHz holds on average over any
window however the host schedules it. The measured topics and the commands cross DDS, as
a driver's would. Run as
``python -m pam_bench.bringup.emulator [--priority N] PARAMS_FILE NODE [NODE ...]``.
"""

from __future__ import annotations

import pathlib
import sys
import time
from typing import Any

from pam_bench.config.nodes import NODES, devices

__all__ = ['chain_order', 'run_emulator', 'main']

def chain_order(names: list[str]) -> list[str]:
    """``names`` in the order the devices step within one tick (the node table's order,
    ``config.nodes``); anything else is not a device."""
    chain = devices(names)
    unknown = [n for n in names if n not in chain]
    if unknown:
        raise ValueError(f'not a device node: {", ".join(unknown)}')
    return chain


DEVICE_PRIORITY = 40
"""SCHED_FIFO priority of the emulator where the machine allows it: below the torque servo's
50, above every ordinary process. Real devices do not stall when the host is busy; the
emulated ones should not either (BENCHMARKS.md, "The bench on a wall clock")."""


CATCH_UP_TICKS = 100
"""A late loop runs the ticks it missed, each stamped at its own due time, so every device
publishes at its rate on average (a device's own clock does not stop when its host is busy):
at most this many per wake-up, the rest at the next ones (a 1 ms tick costs well under 1 ms,
so a backlog drains within a few periods)."""
MAX_BEHIND_S = 1.0
"""Ticks due longer ago than this are dropped and counted (``dropped_ticks``): after a stall
of a second the bench starts again from now instead of replaying it."""


def run_emulator(names: list[str], params: dict[str, Any], priority: int = DEVICE_PRIORITY,
                 namespace: str = '') -> int:
    """Build the device nodes ``names`` in ``namespace`` ('': the root) with ``params``
    (params-file layout) and tick them until SIGINT or SIGTERM, SCHED_FIFO at ``priority``
    where allowed (0: ordinary); return the exit code (2: a bad parameter, one line
    printed)."""
    import importlib

    import rclpy
    from rclpy.exceptions import ParameterException

    from pam_bench.config.scene import node_of_key, settings_of_params_file
    from pam_bench.runtime import intra
    from pam_bench.runtime.params import overrides_of
    from pam_bench.runtime.process import (
        deadline_spin,
        fail_line,
        ignore_interrupts,
        install_interrupt_handlers,
        reject_undeclared,
        serve_services,
    )
    from pam_bench.runtime.profiling import profiled
    from pam_bench.runtime.scheduling import set_realtime_priority
    from pam_bench.runtime.stats import ACK_WAIT_S
    from pam_bench.vocabulary.errors import PamBenchError

    install_interrupt_handlers()
    nodes: list[Any] = []
    bus = intra.IntraProcessBus()
    try:
        rclpy.init()
        try:
            by_node = {node_of_key(k): v for k, v in params.items()}
            settings = settings_of_params_file({n: by_node.get(n, {}) for n in names})
        except PamBenchError as exc:
            print(f'emulator: error: {exc}', file=sys.stderr, flush=True)
            return 2
        for name in chain_order(names):
            t = NODES[name]
            cls = getattr(importlib.import_module(t.module), t.cls)
            overrides = overrides_of(settings[name])
            try:
                node = cls(name, parameter_overrides=overrides, bus=bus,
                           **({'namespace': namespace} if namespace else {}))
                reject_undeclared(node, overrides)
            except (PamBenchError, ParameterException) as exc:
                print(fail_line(name, exc), file=sys.stderr, flush=True)
                return 2
            if node.wall_period_s is None:
                print(f'{name}: error: the emulator runs devices on a wall clock: set lockstep '
                      'false', file=sys.stderr, flush=True)
                return 2
            nodes.append(node)
        periods = [round(n.take_wall_ticks() * 1e9) for n in nodes]
        due: list[int | None] = [None] * len(nodes)
        services = [serve_services(n) for n in nodes]
        now_ns = nodes[0].now_ns
        behind_ns = round(MAX_BEHIND_S * 1e9)

        def tick() -> None:
            t = now_ns()
            for _ in range(CATCH_UP_TICKS):
                stepped = False
                for i, node in enumerate(nodes):
                    d = due[i]
                    if d is None:
                        d = t
                    if t >= d:
                        node.wall_tick(d)
                        bus.drain(1 << 30)
                        due[i] = d + periods[i]
                        stepped = True
                if not stepped:
                    return
            for i, node in enumerate(nodes):      # too far behind: start again from now
                d = due[i]
                if d is not None and t - d > behind_ns:
                    missed = (t - d) // periods[i] + 1
                    node.dropped_ticks += missed
                    due[i] = d + missed * periods[i]

        def poll() -> None:
            bus.refresh()
            for serve in services:
                serve()

        if priority:
            nodes[0].get_logger().info(f'emulator: {set_realtime_priority(priority)}')
        with profiled('emulator'):
            deadline_spin(nodes, tick, min(periods) * 1e-9, poll, poll_period_s=0.02)
    except KeyboardInterrupt:
        pass
    finally:
        ignore_interrupts()
        until = time.monotonic() + ACK_WAIT_S      # one wait for acknowledgments for all
        for node in nodes:
            node.ack_until_s = until
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


def main(argv: list[str] | None = None) -> None:
    """``python -m pam_bench.bringup.emulator PARAMS_FILE NODE [NODE ...]``."""
    from pam_bench.vocabulary.yaml_io import read_yaml
    args = list(sys.argv[1:] if argv is None else argv)
    priority = DEVICE_PRIORITY
    namespace = ''
    while args[:1] in (['--priority'], ['--namespace']) and len(args) > 1:
        if args[0] == '--priority':
            priority = int(args[1])
        else:
            namespace = args[1]
        args = args[2:]
    if len(args) < 2:
        print('usage: python -m pam_bench.bringup.emulator [--priority N] [--namespace NS] '
              'PARAMS_FILE NODE [NODE ...]', file=sys.stderr)
        sys.exit(2)
    sys.exit(run_emulator(args[1:], read_yaml(pathlib.Path(args[0])), priority, namespace))


if __name__ == '__main__':
    main()
