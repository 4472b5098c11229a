"""How a run is laid out and the options of one run, as one typed object.

``Layout`` names the three ways ``bringup.runner.run_scene`` brings a scene up (and the way a
bag records it, ``pam-bench info``); ``RunOptions`` holds everything a run takes besides the
scene and its bag folder.
"""

from __future__ import annotations

import dataclasses
import enum
from typing import Any

__all__ = ['Layout', 'RunOptions', 'ENGINES']

ENGINES = ('twin', 'ros')
"""What runs a sweep's job or a servo comparison: the numpy twin (``pam_bench.twin``, no ROS)
or the ROS nodes."""


class Layout(enum.Enum):
    """Where the nodes of a run live and which clock drives them."""

    COMPOSED = 'composed'
    """Lock-step, every node in one process on the intra-process bus (the default)."""
    PROCESSES = 'separate processes'
    """Lock-step, every node in its own process (as beside drivers; two hosts with netns)."""
    WALL_CLOCK = 'wall clock'
    """No sim clock: devices free-running in an emulator, controllers in their own processes."""

    @classmethod
    def parse(cls, text: str) -> Layout:
        """The layout a bag or a benchmark row names ('one process' in older ones).

        Raises:
            ValueError: not a layout.
        """
        if text == 'one process':
            return cls.COMPOSED
        return cls(text)

    @property
    def lockstep(self) -> bool:
        """Whether the sim clock drives the run."""
        return self is not Layout.WALL_CLOCK


@dataclasses.dataclass(frozen=True)
class RunOptions:
    """Everything ``run_scene`` takes besides the scene and its bag folder.

    Attributes:
        seed: seed of the sensor noise.
        layout: where the nodes live (``Layout``); ``netns`` implies separate processes.
        realtime: lock-step paced to the wall clock.
        device_processes: wall clock: each device in its own process, not the emulator.
        devices_only: wall clock: only the simulated devices, until Ctrl-C.
        netns: (devices' namespace, the others') to run as on two hosts.
        domain_id: the ROS domain (None: the environment's).
        quiet: no progress lines.
        settings: node -> settings replacing the scene's (a bag's own: ``--replay``).
        live: the live view's settings (``config.settings.LiveViewSettings``), or None.
        namespace: wall clock: the ROS namespace of every node ('': the root), so that
            benches share a domain without mixing (``config.topics.in_namespace``).
        buses: wall clock: the register map of the DAQ the devices are served behind, with
            the CiA 402 drive, the drivers in their place ('': no buses; ``bringup.buses``).
        external: wall clock: devices a lab's own drivers stand in for; the run starts the
            others and waits for these (``bringup.external``).
    """

    seed: int = 0
    layout: Layout = Layout.COMPOSED
    realtime: bool = False
    device_processes: bool = False
    devices_only: bool = False
    netns: tuple[str, str] | None = None
    domain_id: int | None = None
    quiet: bool = False
    settings: dict[str, Any] | None = None
    live: Any = None
    namespace: str = ''
    buses: str = ''
    external: tuple[str, ...] = ()
