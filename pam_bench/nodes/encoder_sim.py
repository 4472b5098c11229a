"""encoder_sim: the 16-bit absolute encoder on the pulley shaft (``EncoderModel``).

Input ``sim/pulley/state`` of the same exchange (joint ``pulley``, rad); output
``encoder/joint_state`` (JointState, joint ``pulley``: quantised angle in rad and its
finite-difference rate in rad/s). On a wall clock it reads the latest angle at ``rate_hz``.
"""

from __future__ import annotations

from typing import Any

from sensor_msgs.msg import JointState

from pam_bench.config import topics
from pam_bench.config.settings import EncoderSettings
from pam_bench.models.sensors import EncoderModel
from pam_bench.runtime.base import BenchNode
from pam_bench.runtime.process import run_node
from pam_bench.runtime.stamped import stamped

__all__ = ['EncoderSim', 'main']


class EncoderSim(BenchNode):
    """Thin node over ``EncoderModel``."""

    SETTINGS = EncoderSettings

    def __init__(self, name: str = 'encoder', **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        s: EncoderSettings = self.settings
        self.model = EncoderModel(s.encoder)
        self.topic = topics.PULLEY_STATE
        self.angle_rad = 0.0
        self.pub = self.create_step_publisher(JointState, topics.ENCODER)
        self.sync_input(JointState, self.topic, same_step=True)
        self.start_stepping()

    def on_step(self, t_ns: int, dt_s: float, inputs: dict[str, Any]) -> None:
        """Read the pulley angle at the end of the exchange."""
        js = inputs[self.topic]
        self.angle_rad = js.position[list(js.name).index('pulley')]
        angle, rate = self.model.measure(self.angle_rad, dt_s)
        reported = self.faulty(angle)               # injected faults (wall clock)
        if reported is None:
            return
        self.pub.publish(stamped(JointState, t_ns, name=['pulley'], position=[reported],
                                 velocity=[rate]))


def main(args: list[str] | None = None) -> None:
    """Run the node."""
    run_node(EncoderSim, args)


if __name__ == '__main__':
    main()
