"""A device node as a ROS client nobody here wrote meets it (issue 52): started as its console
script, driven by a plain rclpy client. An invalid lifecycle transition is refused and the node
lives on; deactivate publishes the vented state; a node waiting for an input names it on
/diagnostics; a status says the present condition (ERROR while bad commands come, OK once they
stop)."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from typing import Any

import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetState
from pam_bench_interfaces.msg import MuscleState, ValveCommand
from rclpy.executors import SingleThreadedExecutor
from sensor_msgs.msg import FluidPressure

from pam_bench.models.constants import ATMOSPHERE_PA

pytestmark = pytest.mark.wallclock


class Client:
    """A plain rclpy node: lifecycle calls, commands, and what comes back."""

    def __init__(self) -> None:
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx)
        self.node = rclpy.create_node('lab_client', context=self.ctx)
        self.change = self.node.create_client(ChangeState, '/valve_1/change_state')
        self.get = self.node.create_client(GetState, '/valve_1/get_state')
        self.cmd = self.node.create_publisher(ValveCommand, '/valve_1/command', 10)
        self.muscle = self.node.create_publisher(MuscleState, '/sim/muscle_1/state', 10)
        self.pressures: list[float] = []
        self.statuses: list[tuple[str, int, str]] = []
        self.node.create_subscription(FluidPressure, '/valve_1/pressure',
                                      lambda m: self.pressures.append(m.fluid_pressure), 100)
        self.node.create_subscription(DiagnosticArray, '/diagnostics', self._diag, 100)
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)

    def _diag(self, msg: DiagnosticArray) -> None:
        self.statuses += [(s.name, s.level[0] if isinstance(s.level, bytes) else s.level,
                           s.message) for s in msg.status]

    def spin(self, seconds: float, feed: float | None = None) -> None:
        """Serve callbacks for ``seconds``; with ``feed`` (V) send the muscle's state and
        that command every 10 ms, as a controller and the muscle would."""
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            if feed is not None:
                self.muscle.publish(MuscleState(volume=3e-4))
                self.cmd.publish(ValveCommand(voltage=feed))
            self._spin_once()

    def _spin_once(self) -> None:
        self.executor.spin_once(timeout_sec=0.01)

    def call(self, client: Any, request: Any, tries: int = 1) -> Any:
        """The response to ``request``; a request that changes nothing may be sent ``tries``
        times: a service's first response can be lost while DDS still matches the server's
        reply writer to this client's reader (rmw_fastrtps waits 100 ms for it)."""
        assert client.wait_for_service(timeout_sec=15.0)
        for _ in range(tries):
            future = client.call_async(request)
            end = time.monotonic() + 10.0 / tries
            while not future.done() and time.monotonic() < end:
                self._spin_once()
            if future.done():
                return future.result()
            client.remove_pending_request(future)
        return None

    def transition(self, tid: int) -> bool:
        return bool(self.call(self.change, ChangeState.Request(
            transition=Transition(id=tid))).success)

    def state(self) -> str:
        return str(self.call(self.get, GetState.Request(), tries=3).current_state.label)

    def levels(self, concern: str) -> list[tuple[int, str]]:
        return [(lvl, msg) for name, lvl, msg in self.statuses
                if name == f'valve_1: {concern}']

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.ctx)


def test_a_device_survives_a_ros_client(ros_domain: int) -> None:
    env = {**os.environ, 'ROS_DOMAIN_ID': str(ros_domain)}
    valve = subprocess.Popen([os.path.join(os.path.dirname(sys.executable), 'valve_sim'),
                              '--ros-args', '-r', '__node:=valve_1', '-p', 'lockstep:=false',
                              '-p', 'managed:=true'], env=env, stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT, text=True)
    client = Client()
    try:
        # asked first what changes nothing, as a careful client does: once that is answered,
        # the node and this client have found each other
        assert client.state() == 'unconfigured'
        assert client.transition(Transition.TRANSITION_CONFIGURE)
        assert client.transition(Transition.TRANSITION_ACTIVATE)
        # active, no muscle yet: it waits and says for what
        client.spin(2.5)
        waiting = client.levels('connections')
        assert waiting and waiting[-1][0] == 1 and '/sim/muscle_1/state' in waiting[-1][1], \
            client.statuses
        # an invalid transition: refused, the node lives on, a WARN names it
        assert not client.transition(Transition.TRANSITION_ACTIVATE)
        assert valve.poll() is None and client.state() == 'active'
        assert any('refused in state active' in m for _, m in client.levels('lifecycle'))
        # pressurised, then one bad command amid valid ones: ERROR, then OK again
        client.spin(1.5, feed=4.0)
        assert client.pressures and client.pressures[-1] > ATMOSPHERE_PA + 1e5
        client.cmd.publish(ValveCommand(voltage=float('nan')))
        client.spin(3.0, feed=4.0)
        inputs = client.levels('inputs')
        assert inputs[0][0] == 2 and 'rejected' in inputs[0][1], inputs
        assert inputs[-1][0] == 0 and 'none rejected' in inputs[-1][1], inputs
        # deactivate: the vented pressure is the last one published
        assert client.transition(Transition.TRANSITION_DEACTIVATE)
        client.spin(1.0)
        assert client.pressures[-1] == pytest.approx(ATMOSPHERE_PA)
        assert valve.poll() is None
    finally:
        client.close()
        valve.terminate()
        out = valve.communicate(timeout=20)[0]
    assert 'Traceback' not in out and 'RCLError' not in out, out
