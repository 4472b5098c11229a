"""A lab's own device beside the simulated bench: ``run --wallclock --external NAME`` and
``emulate --external NAME`` start every simulated device but the named ones.

``check_external`` refuses, before anything starts, a name that is not a device of the scene,
a device named twice, and a device whose ground truth a simulated device still needs (a real
valve publishes no ``sim/valve_1/samples`` for the simulated muscle: the sensors, load cells and
encoder, can be swapped alone; a valve, muscle or drive with the devices that read them).
``await_external`` then waits, before the controllers start, until every named device
publishes its topics of the driver contract as ``check-drivers`` judges them, saying which
device it waits for and why.
"""

from __future__ import annotations

import os
import time
from collections.abc import Sequence

from pam_bench.bringup.errors import LayoutError
from pam_bench.config.nodes import MEASURED, devices, ground_truth_of
from pam_bench.config.topics import absolute
from pam_bench.vocabulary.params import hint

__all__ = ['check_external', 'await_external', 'AWAIT_S', 'PROBE_S']

AWAIT_S = 120.0
"""The longest a run waits for its external devices to meet the contract (s)."""
PROBE_S = 1.5
"""How long each look at them listens (s): a rate needs a second of messages."""


def check_external(scene_name: str, nodes: list[str], external: Sequence[str],
                   buses: str = '') -> list[str]:
    """The external devices, checked (module docstring); [] for none.

    Raises:
        LayoutError: one line naming the bad name and what to do.
    """
    names = list(external)
    if not names:
        return []
    if buses:
        raise LayoutError('--external and --buses: the buses replace every device with '
                          'their drivers; name the devices your drivers replace without '
                          '--buses')
    sims = devices(nodes)
    for n in names:
        if names.count(n) > 1:
            raise LayoutError(f'--external: device {n!r} named {names.count(n)} times')
        if n not in sims:
            raise LayoutError(f'--external {n!r}: not a device of scene {scene_name} '
                              f'({hint(n, sims)})')
    for d in sims:
        if d in names:
            continue
        lost = [n for n in ground_truth_of(d, nodes) if n in names]
        if lost:
            raise LayoutError(f'--external {lost[0]}: the simulated {d} reads the simulated '
                              f"{lost[0]}'s ground truth, which a real {lost[0]} does not "
                              f'publish: make {d} external too (the sensors, load_cell_N and '
                              'encoder, can be swapped alone)')
    return names


def await_external(nodes: list[str], external: Sequence[str], namespace: str, domain: int,
                   quiet: bool, timeout_s: float = AWAIT_S) -> None:
    """Wait until every device of ``external`` publishes its contract topics as
    ``check-drivers`` judges them (module docstring).

    Raises:
        LayoutError: they did not within ``timeout_s`` (the last reason, named).
    """
    from pam_bench.config.nodes import controllers
    from pam_bench.nodes.driver_probe import probe_drivers
    topics = {absolute(MEASURED[n]): n for n in external if MEASURED.get(n)}
    if not topics:
        return
    os.environ['ROS_DOMAIN_ID'] = str(domain)
    end = time.monotonic() + timeout_s
    said = ''
    while True:
        verdicts = probe_drivers(controllers(nodes) or ['sequencer'], PROBE_S, settle_s=1.0,
                                 namespace=namespace, only=list(topics))
        failed = [v for v in verdicts if not v.ok]
        if not failed:
            if not quiet:
                print(f'external {", ".join(external)}: meets the driver contract', flush=True)
            return
        v = failed[0]
        device = next((n for t, n in topics.items() if v.topic.endswith(t)), v.topic)
        line = f'waiting for {device} ({v.topic}: {v.reason})'
        if time.monotonic() > end:
            raise LayoutError(f'{line} for {timeout_s:g} s: check it with pam-bench '
                              'check-drivers')
        if line != said and not quiet:
            print(line, flush=True)
            said = line
