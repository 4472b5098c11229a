"""The bench node: typed settings, diagnostics, its stepping, and one mixin per concept.

Every node of the bench is a ``BenchNode``: it declares its ROS parameters from its settings
dataclass (``SETTINGS``, ``config.settings``; ``runtime.params``) and keeps the result in
``settings``, publishes diagnostics (``runtime.core``), and holds its stepping
(``runtime.stepping``): in lock-step with the sim clock (``runtime.lockstep``) or on its own
wall clock (``runtime.wallclock``), declared through ``sync_input`` and
``create_step_publisher``. The concepts around it are mixins that keep to their own state:
the wall-clock loop and helpers (``runtime.wallclock``), faults
injected on a wall clock (``runtime.faults``), its publish counts and loop periods kept for
the run's statistics (``runtime.stats``), its tunable settings changed while it runs
(``runtime.tuning``) and, for a device, a driver or the torque servo on a wall clock, a
lifecycle (``runtime.lifecycle``). ``spin_mode`` says how its process spins it
(``runtime.process.run_node``). In lock-step a node starts without its parameter services
(parameters are read once; fewer entities per wake-up); on a wall clock it has them.
"""

from __future__ import annotations

from typing import Any, ClassVar

from diagnostic_msgs.msg import DiagnosticArray

from pam_bench.config import topics
from pam_bench.config.settings import DeviceSettings, NodeSettings
from pam_bench.runtime.core import NodeCore, Spin
from pam_bench.runtime.diagnostics import Diagnostics
from pam_bench.runtime.faults import FaultInjection
from pam_bench.runtime.intra import IntraProcessBus, bus_publisher
from pam_bench.runtime.lifecycle import Lifecycle
from pam_bench.runtime.lockstep import LockstepStepping
from pam_bench.runtime.messages import import_rosidl_lean
from pam_bench.runtime.params import declare_settings
from pam_bench.runtime.qos import DRIVER, LOCKSTEP, RELIABLE, SENSOR
from pam_bench.runtime.stats import Stats
from pam_bench.runtime.stepping import Stepping
from pam_bench.runtime.tuning import Tuning
from pam_bench.runtime.wallclock import WallClock, WallClockStepping
from pam_bench.sim.lockstep import InputSpec, StopRequest

__all__ = ['BenchNode', 'Spin', 'RELIABLE', 'LOCKSTEP', 'DRIVER', 'SENSOR', 'NodeCore']

STEPPINGS: tuple[type[Stepping], ...] = (LockstepStepping, WallClockStepping)
"""The two steppings (mypy checks that each is a ``Stepping``)."""


class BenchNode(WallClock, FaultInjection, Stats, Tuning, Lifecycle):
    """Base of every bench node (module docstring)."""

    SETTINGS: ClassVar[type] = NodeSettings
    """The node's settings dataclass; every leaf is a declared parameter."""
    GRACEFUL_STOP: ClassVar[bool] = False
    """SIGINT and SIGTERM end its lean loop between messages, never inside a callback."""
    INTERRUPTED_CODE: ClassVar[int] = 0
    """Exit code of its process when interrupted (Ctrl-C, SIGTERM)."""

    def __init__(self, name: str, bus: IntraProcessBus | None = None, **kwargs: Any) -> None:
        """``bus``: the intra-process bus of a composed process (``runtime.intra``); None:
        DDS only. The other keywords go to rclpy's ``Node``."""
        # Parameters are read once at start-up; without the six parameter services every
        # executor wake-up waits on far fewer entities (about 2x faster lock-step).
        kwargs.setdefault('start_parameter_services', False)
        self._bus = bus
        import_rosidl_lean()                      # before the first type support is loaded
        super().__init__(name, **kwargs)
        self.settings = declare_settings(self, self.SETTINGS)
        self.lockstep = bool(getattr(self.settings, 'lockstep', False))
        self.rejected_count = 0
        self._fqn = self.get_fully_qualified_name()
        self._diag_pub = bus_publisher(self, DiagnosticArray, topics.DIAGNOSTICS, RELIABLE)
        s = self.settings
        self.diagnostics = Diagnostics(
            self, self._diag_pub.publish,
            getattr(s, 'hardware_id', '') or f'pam_bench/{self.get_name()}',
            float(getattr(s, 'diagnostics_period_s', 1.0)))
        self.stop_request: StopRequest | None = None   # sent with every acknowledgement
        self.max_next_step_s = 0.0        # longest next exchange step wanted (0: any)
        self.stepping: LockstepStepping | WallClockStepping = (
            LockstepStepping(self) if self.lockstep else WallClockStepping(self))
        self._init_wallclock()
        self._init_faults()
        self._init_stats()
        self._init_tuning()
        self._init_lifecycle()
        if getattr(self.settings, 'lockstep', True) is False:
            from rclpy.parameter_service import ParameterService
            self._parameter_service = ParameterService(self)

    # --- the stepping (runtime.stepping) -------------------------------------------------
    def sync_input(self, msg_type: type, topic: str, raw: bool = False,
                   same_step: bool = False, samples: bool = False,
                   from_start: bool = False, stamped: bool = False,
                   blocks: bool = False) -> None:
        """Subscribe to a synchronous input: in lock-step buffered by stamp and required at
        every step (``same_step``, ``samples``, ``from_start``, ``stamped``, ``blocks``:
        ``runtime.lockstep``, ``sim.lockstep``; ``raw``: kept as CDR bytes until a step uses
        it); on a wall clock the latest message."""
        self.stepping.input(msg_type, topic, raw,
                            InputSpec(same_step, samples, from_start, stamped, blocks))

    def create_step_publisher(self, msg_type: type, topic: str) -> Any:
        """A publisher of a step output (lock-step: sent again when the clock repeats a
        tick; wall clock: a counted driver publisher)."""
        return self.stepping.publisher(msg_type, topic)

    def publish_each(self, pub: Any, msgs: list[Any]) -> None:
        """Publish ``msgs`` in order on ``pub``: at once where it takes lists (a lock-step
        step publisher, ``runtime.intra``), else one by one."""
        many = getattr(pub, 'publish_many', None) if self.lockstep else None
        if many is not None and len(msgs) > 1:
            many(msgs)
        else:
            for m in msgs:
                pub.publish(m)

    def start_lockstep(self) -> None:
        """Start stepping on /clock (after every ``sync_input``)."""
        self.stepping.start()

    def start_stepping(self) -> None:
        """Start a device stepping (call after all sync_input): in lock-step on /clock, else
        on its own clock at ``rate_hz``, with the faults of ``faults_yaml``."""
        s = self.settings
        assert isinstance(s, DeviceSettings)
        self.start_faults(s.faults_yaml)
        if self.lockstep:
            self.start_lockstep()
        else:
            self.start_wall_ticks(1.0 / s.rate_hz)

    def spin_mode(self) -> Spin:
        """How the node's process spins it: on a monotonic deadline when it ticks on a wall
        clock, else on its subscriptions alone (a node with timers, services or actions of
        its own overrides this)."""
        return Spin.DEADLINE if self.wall_period_s is not None else Spin.LEAN

    def destroy_node(self) -> None:
        """Step no more, let subscribers acknowledge what was published (a recorder gets the
        last messages), write the stats file, then go."""
        self.stepping.stop()
        self.wait_acknowledged()
        try:
            self.write_stats()
        except OSError as exc:
            self.get_logger().error(f'stats file: {exc}')
        super().destroy_node()
