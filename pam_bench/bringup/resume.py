"""Resume a scene's protocol after an interrupted run: where to restart, from its bag."""

from __future__ import annotations

import pathlib

from pam_bench.bags.bagread import read_bags
from pam_bench.config.protocols import protocol_schedule
from pam_bench.config.scene import Scene
from pam_bench.protocol.schedules import resume_index

__all__ = ['resume_reading']


def resume_reading(scene: Scene, bag: str | pathlib.Path) -> tuple[int, int]:
    """The reading to restart the scene's protocol at, and the number of readings.

    The points in ``bag`` (a run of the same scene, complete or cut short; its last bag closes
    valid whatever stopped it) mark the readings taken; the run restarts at the first reading
    the bag lacks (the sequencer first takes the bench along that series' path to it:
    ``protocol.schedules.with_approach``).

    Raises:
        bags.bagread.BagError: the bag cannot be read or holds no points.
        ParameterError: the scene's protocol is unknown or malformed.
    """
    readings, _ = protocol_schedule(scene.protocol, scene.protocol_overrides)
    data = read_bags([bag])
    done = {(name, int(s), int(k)) for name, pts in data.points.items()
            for s, k in zip(pts.series, pts.step, strict=True)}
    return resume_index(readings, done), len(readings)
