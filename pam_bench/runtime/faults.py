"""Faults injected into a simulated device on a wall clock (``sim.faults``): when they act and
what they do to a measured value. Their time base is the run's start: the protocol's start as
the first protocol status past idle states it (its ``elapsed`` back from its arrival, so a
status missed while discovery was still matching does not shift the faults), or the arrival of
the first servo state."""

from __future__ import annotations

import zlib
from typing import Any

import numpy as np

from pam_bench.config import topics
from pam_bench.runtime.core import NodeCore
from pam_bench.runtime.qos import RELIABLE
from pam_bench.sim.faults import Fault, parse_faults, sensor_value
from pam_bench.vocabulary.errors import ParameterError
from pam_bench.vocabulary.yaml_io import load_yaml

__all__ = ['FaultInjection']


class FaultInjection(NodeCore):
    """A device's injected faults (module docstring)."""

    def _init_faults(self) -> None:
        self.faults: list[Fault] = []
        self._fault_epoch_ns: int | None = None
        self._fault_rng = np.random.default_rng(zlib.crc32(self.get_name().encode()))

    def start_faults(self, text: str) -> None:
        """Take the faults of ``faults_yaml`` (YAML list) and subscribe to the run's start.

        Raises:
            ParameterError: a bad fault, or faults on a lock-step node.
        """
        self.faults = parse_faults(load_yaml(text, 'faults') if text else [], [self.get_name()])
        if self.faults and self.lockstep:
            raise ParameterError(f'{self.get_name()}: faults run on a wall clock (lockstep '
                                 'false)')
        if self.faults:
            from pam_bench_interfaces.msg import ProtocolStatus, TorqueServoState
            for cls, topic in ((ProtocolStatus, topics.STATUS),
                               (TorqueServoState, topics.SERVO_STATE)):
                self.create_subscription(cls, topic, self._run_started, RELIABLE)

    def _run_started(self, msg: Any) -> None:
        # an idle status (waiting for its inputs, 0 s elapsed) comes before the protocol's
        # start, however long bring-up takes: the faults' clock starts with the protocol
        idle = getattr(msg, 'STATE_IDLE', None)          # a protocol status's own constant
        if self._fault_epoch_ns is None and (idle is None or msg.state != idle):
            elapsed_s = float(getattr(msg, 'elapsed', 0.0))
            self._fault_epoch_ns = (int(self.get_clock().now().nanoseconds)
                                    - round(max(elapsed_s, 0.0) * 1e9))

    def fault_time_s(self) -> float:
        """Seconds since the run started; -1 before."""
        last_ns = self.stepping.last_ns
        if self._fault_epoch_ns is None or last_ns is None:
            return -1.0
        return (last_ns - self._fault_epoch_ns) * 1e-9

    def faulty(self, value: float) -> float | None:
        """The measured ``value`` as the injected faults make it (None: not published)."""
        if not self.faults:
            return value
        return sensor_value(self.faults, self.fault_time_s(), value,
                            float(self._fault_rng.standard_normal()),
                            float(self._fault_rng.random()))

    def fault_active(self, kind: str) -> bool:
        """Whether an injected fault of ``kind`` acts now."""
        t = self.fault_time_s()
        return any(f.kind == kind and f.active(t) for f in self.faults)
