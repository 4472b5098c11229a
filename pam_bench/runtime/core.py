"""What every bench node shares before its stepping: settings, diagnostics and the hooks.

``NodeCore`` is the rclpy ``Node`` the concept mixins of ``runtime.base`` build on
(``wallclock``, ``faults``, ``stats``, ``tuning``, ``lifecycle``) and that a node's stepping
(``runtime.stepping``) calls back: it declares what they read of each other and the hooks a
device or controller overrides (``on_start``, ``on_step``, ``on_fault``).
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable
from typing import Any

from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.node import Node

from pam_bench.runtime.diagnostics import Diagnostics
from pam_bench.runtime.intra import IntraProcessBus

__all__ = ['NodeCore', 'Spin', 'Output']

Output = tuple[Callable[..., None], Any]
"""A publish and its message, kept to be sent again."""


class Spin(enum.Enum):
    """How a node's process spins it (``runtime.process.run_node``)."""

    LEAN = 'lean'              # subscriptions only: one wait set (``lean_spin``)
    DEADLINE = 'deadline'      # a wall-clock loop on a monotonic deadline (``deadline_spin``)
    EXECUTOR = 'executor'      # rclpy's executor: timers, services, actions


class NodeCore(Node):
    """State and hooks shared by the concept mixins (module docstring)."""

    settings: Any
    lockstep: bool
    _bus: IntraProcessBus | None
    _fqn: str
    _diag_pub: Any
    diagnostics: Diagnostics
    stepping: Any                     # runtime.stepping.Stepping
    max_next_step_s: float
    stop_request: Any
    wall_period_s: float | None
    rejected_count: int
    exit_code: int | None

    # --- diagnostics (runtime.diagnostics) ---------------------------------------------
    def diagnose(self, level: bytes, message: str, concern: str = 'state',
                 passing: bool = False, **values: Any) -> None:
        """A status of one of this node's concerns (``runtime.diagnostics``: sent at once
        when its level changes, with the 1 Hz summary otherwise; logs throttled;
        ``passing``: an event, back to OK at a summary with none since)."""
        self.diagnostics.stamp_ns = self.stepping.last_ns or self.diagnostics.stamp_ns
        self.diagnostics.report(concern, level, message, passing, **values)

    def reject(self, what: str, value: Any) -> None:
        """Count and diagnose a rejected input (concern ``inputs``, ERROR while rejected
        inputs come, OK again at the first summary without one)."""
        self.rejected_count += 1
        self.diagnose(DiagnosticStatus.ERROR, f'rejected {what}: {value!r}', 'inputs',
                      passing=True, rejected_count=self.rejected_count)

    @staticmethod
    def finite(*values: float) -> bool:
        """True when every value is a finite float."""
        return all(isinstance(v, (int, float)) and math.isfinite(v) for v in values)

    # --- provided by the mixins of runtime.base ------------------------------------------
    def counted(self, pub: Any, topic: str) -> Any:
        """Count what ``pub`` puts on DDS; returns ``pub`` (``runtime.stats``)."""
        raise NotImplementedError

    def count_periods(self, period_s: float) -> None:
        """Keep the statistics of a loop ticking every ``period_s`` (``runtime.stats``)."""
        raise NotImplementedError

    def count_tick(self) -> None:
        """One tick of the node's loop, now (``runtime.stats``)."""
        raise NotImplementedError

    def apply_tuning(self) -> None:
        """Take the settings changed since the last step (``runtime.tuning``)."""
        raise NotImplementedError

    def now_ns(self) -> int:
        """The node's clock, ns (``runtime.wallclock``)."""
        raise NotImplementedError

    def wall_inputs(self, inputs: dict[str, Any], dt_s: float) -> dict[str, Any]:
        """The latest inputs adapted to a wall-clock step (``runtime.wallclock``)."""
        raise NotImplementedError

    def recorder_listens(self, topic: str, recorder: str = 'recorder') -> bool:
        """Whether the run's recorder subscribes to ``topic`` (``runtime.wallclock``)."""
        raise NotImplementedError

    def may_step(self) -> bool:
        """Whether the node steps now: its lifecycle is active (``runtime.lifecycle``)."""
        raise NotImplementedError

    # --- to override -------------------------------------------------------------------
    def on_start(self, t_ns: int) -> None:
        """Called once at t_0, when the inputs have publishers."""

    def on_step(self, t_ns: int, dt_s: float, inputs: dict[str, Any]) -> None:
        """Advance the model to ``t_ns`` over ``dt_s``; ``inputs`` maps topic -> msg at t_(k-1)
        (empty at the first step). Publish every output stamped ``t_ns``."""
        raise NotImplementedError

    def on_fault(self, reason: str) -> None:
        """Put the device in its safe state after a failed step."""

    def step_failed(self, exc: Exception) -> None:
        """A step raised: diagnose it and put the node in its safe state (a callback never
        lets an exception out)."""
        self.diagnose(DiagnosticStatus.ERROR, f'step failed: {exc}')
        self.on_fault(str(exc))
