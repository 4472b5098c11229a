"""How a node steps: an object it holds (``node.stepping``) behind one protocol.

A bench node steps either in lock-step with the sim clock (``runtime.lockstep
.LockstepStepping``: inputs buffered by stamp, one step per /clock tick, the acknowledgement)
or on its own wall clock (``runtime.wallclock.WallClockStepping``: the latest inputs, a fixed
grid that follows the clock). The node chooses one at construction from its ``lockstep``
setting and declares its synchronous inputs and step outputs through it; the stepping calls
the node's hooks (``on_start``, ``on_step``, ``step_failed``) and owns its own state, so no
part of the node writes another's.
"""

from __future__ import annotations

from typing import Any, Protocol

from pam_bench.sim.lockstep import InputSpec

__all__ = ['Stepping']


class Stepping(Protocol):
    """A node's stepping (module docstring)."""

    last_ns: int | None
    """The stamp of the node's latest step or tick, ns (None before its first)."""

    def input(self, msg_type: type, topic: str, raw: bool = False,
              spec: InputSpec | None = None) -> None:
        """Subscribe to a synchronous input (``spec``: how a lock-step takes it)."""
        ...

    def publisher(self, msg_type: type, topic: str) -> Any:
        """A publisher of a step output."""
        ...

    def start(self) -> None:
        """Start stepping (after every input and output is declared)."""
        ...

    def step(self, t_ns: int | None = None) -> None:
        """Step when due: to the pending tick (lock-step) or at ``t_ns`` (wall clock)."""
        ...

    def fault(self, exc: Exception) -> None:
        """A step raised ``exc``: the node diagnoses it and goes to its safe state."""
        ...

    def stop(self) -> None:
        """Step no more."""
        ...
