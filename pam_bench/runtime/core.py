"""What every bench node shares before its stepping: settings, diagnostics and the hooks.

``NodeCore`` is the rclpy ``Node`` the concept mixins of ``runtime.base`` build on
(``lockstep``, ``wallclock``, ``faults``, ``stats``): it holds the state they share and the
hooks a device or controller overrides (``on_start``, ``on_step``, ``on_fault``).
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.node import Node

from pam_bench.runtime.intra import IntraProcessBus
from pam_bench.runtime.messages import time_of

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
    _sync: dict[str, dict[int, Any]]
    _latest: dict[str, Any]
    _last_ns: int | None
    _sent: list[Output]
    _start_outputs: list[Output] | None
    rejected_count: int

    # --- diagnostics -------------------------------------------------------------------
    def diagnose(self, level: bytes, message: str, **values: Any) -> None:
        """Publish one DiagnosticStatus for this node and log it."""
        st = DiagnosticStatus(level=level, name=self.get_fully_qualified_name(),
                              message=message, hardware_id='pam_bench_sim')
        st.values = [KeyValue(key=k, value=str(v)) for k, v in values.items()]
        arr = DiagnosticArray()
        arr.header.stamp = time_of(self._last_ns or 0)
        arr.status = [st]
        self._diag_pub.publish(arr)
        if level == DiagnosticStatus.OK:
            self.get_logger().info(message)
        elif level == DiagnosticStatus.WARN:
            self.get_logger().warning(message)
        else:
            self.get_logger().error(message)

    def reject(self, what: str, value: Any) -> None:
        """Log, count and diagnose a rejected input."""
        self.rejected_count += 1
        self.diagnose(DiagnosticStatus.ERROR, f'rejected {what}: {value!r}',
                      rejected_count=self.rejected_count)

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
