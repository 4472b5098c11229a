"""load_cell_sim: the strain-gauge load cell of one muscle (``LoadCellModel``).

Input ``sim/muscle_N/samples`` of the same exchange (the true tension at every sub-step);
output ``load_cell_N/force`` (WrenchStamped, force.x in N, 16-bit quantised, seeded noise,
saturating at +-2 kN with a diagnostic): one reading at the end of the exchange, or, while a
1 kHz record is on (the samples' ``record``), one per sample, stamped at the sample's time.
On a wall clock it reads the latest tension at ``rate_hz``.
"""

from __future__ import annotations

import zlib
from typing import Any

from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import WrenchStamped
from pam_bench_interfaces.msg import MuscleSamples

from pam_bench.config import topics
from pam_bench.config.settings import LoadCellSettings
from pam_bench.models.sensors import LoadCellModel
from pam_bench.runtime.base import BenchNode
from pam_bench.runtime.messages import ForceSamples, force_reading
from pam_bench.runtime.process import run_node

__all__ = ['LoadCellSim', 'main']


class LoadCellSim(BenchNode):
    """Thin node over ``LoadCellModel``."""

    SETTINGS = LoadCellSettings

    def __init__(self, name: str = 'load_cell_1', **kwargs: Any) -> None:
        super().__init__(name, **kwargs)
        s: LoadCellSettings = self.settings
        self.channel = s.channel
        self.model = LoadCellModel(s.load_cell, seed=s.seed + zlib.crc32(name.encode()))
        self.topic = topics.muscle_samples(self.channel)
        self.force_n = 0.0
        self.frame_id = f'load_cell_{self.channel}'
        self._was_saturated = False
        self.pub = self.create_step_publisher(WrenchStamped, topics.load_cell_force(self.channel))
        self.sync_input(MuscleSamples, self.topic, same_step=True)
        self.start_stepping()

    def wall_inputs(self, inputs: dict[str, Any], dt_s: float) -> dict[str, Any]:
        """One reading per tick of its own (the samples' record flag is lock-step only)."""
        m: MuscleSamples = inputs[self.topic]
        inputs[self.topic] = MuscleSamples(step=[dt_s], force=[m.force[-1]], record=False)
        return inputs

    def on_step(self, t_ns: int, dt_s: float, inputs: dict[str, Any]) -> None:
        """Measure the true tension at the end of the exchange (every sample during a record).

        In a composed run, where the topic's readers all take them, the samples before the
        exchange's last go as one ``ForceSamples`` block (the same readings; the last stays a
        message on the grid)."""
        m: MuscleSamples = inputs[self.topic]
        samples = [(t_ns, m.force[-1])]
        if m.record:
            t0 = t_ns - round(dt_s * 1e9)
            elapsed = 0.0
            samples = []
            for d, f in zip(m.step, m.force, strict=True):
                elapsed += d
                samples.append((t0 + round(elapsed * 1e9), f))
            samples[-1] = (t_ns, samples[-1][1])
        measured, saturated = self.model.measure_many([f for _, f in samples])
        blocks = getattr(self.pub, 'blocks_taken', None)
        if len(samples) > 1 and not self.faults and self.lockstep and blocks and blocks():
            forces = measured.tolist()
            if self._was_saturated or saturated.any():
                for (_, force), sat in zip(samples, saturated.tolist(), strict=True):
                    self._saturation(sat, force)
            self.force_n = samples[-1][1]
            stamps = [t for t, _ in samples]
            self.pub.publish_many([ForceSamples(stamps[:-1], forces[:-1], self.frame_id),
                                   force_reading(stamps[-1], self.frame_id, forces[-1])])
            return
        out = []
        for (stamp, force), f, sat in zip(samples, measured.tolist(), saturated.tolist(),
                                          strict=True):
            self.force_n = force
            self._saturation(sat, force)
            reported = self.faulty(f)             # injected faults (wall clock)
            if reported is None:
                continue
            out.append(force_reading(stamp, self.frame_id, reported))
        self.publish_each(self.pub, out)

    def _saturation(self, saturated: bool, force_n: float) -> None:
        """A diagnostic when the reading enters or leaves saturation (``force_n``: the true
        tension, N)."""
        if saturated != self._was_saturated:
            self._was_saturated = saturated
            level = DiagnosticStatus.WARN if saturated else DiagnosticStatus.OK
            state = 'saturated' if saturated else 'in range'
            self.diagnose(level, f'load cell {state}', force_n=force_n)


def main(args: list[str] | None = None) -> None:
    """Run the node."""
    run_node(LoadCellSim, args)


if __name__ == '__main__':
    main()
