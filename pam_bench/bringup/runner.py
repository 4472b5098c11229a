"""Bring a scene up, run it, shut everything down, in the layout asked for.

``run_scene`` resolves the scene's settings (``config.scene.Scene.settings``), describes the run
for the bag (``provenance``), and hands it to a layout: ``composed`` (every node in one
process), ``processes`` (one process per node, or two hosts with ``netns``) or ``wallclock``
(a real bench's layout on the wall clock). ``common`` is what they share.
"""

from __future__ import annotations

import copy
import dataclasses
import os
import tempfile
from typing import Any

import yaml

from pam_bench.bringup.common import RunResult, ros_env, write_params_file
from pam_bench.bringup.errors import LayoutError
from pam_bench.bringup.live import live_topics, live_view
from pam_bench.config.scene import Scene, params_file
from pam_bench.config.settings import LiveViewSettings

__all__ = ['RunResult', 'ros_env', 'run_scene', 'write_params_file']


def run_scene(scene: Scene, out_dir: str, seed: int = 0, realtime: bool = False,
              one_process: bool = True, domain_id: int | None = None,
              quiet: bool = False, wallclock: bool = False,
              device_processes: bool = False, devices_only: bool = False,
              settings: dict[str, Any] | None = None,
              netns: tuple[str, str] | None = None,
              live: LiveViewSettings | None = None) -> RunResult:
    """Run ``scene``, recording into ``out_dir``; return the clock's summary. A lock-step run is
    composed in this process by default (``one_process``; False: one process per node, as
    beside drivers; ``netns`` implies it). With
    ``devices_only`` (wall clock) only the simulated devices run, until Ctrl-C: a bench to
    point a lab's own controllers or ``check-drivers`` at. ``settings`` (node -> settings: the
    ones a bag recorded, ``--replay``) replace the scene's. ``netns`` (device namespace,
    other namespace) runs the simulated devices and the other nodes in two network
    namespaces, as on two hosts, with DDS discovery on their subnet (separate processes).
    ``live`` serves the recorded topics to Foxglove during the run (``bringup.live``; its
    ``topics`` filled from the recorder's when empty).

    Raises:
        LiveViewError: the live view cannot start (its port is taken).
    """
    settings = copy.deepcopy(settings) if settings else scene.settings(out_dir, seed, realtime)
    if netns or wallclock:
        one_process = False
    if 'recorder' in settings:
        from pam_bench.bringup.provenance import run_description
        rec = dataclasses.replace(settings['recorder'], out_dir=out_dir, run_yaml='',
                                  end_file='')
        settings['recorder'] = rec
        layout = ('wall clock' if wallclock else 'composed' if one_process
                  else 'separate processes')
        fd, end_file = tempfile.mkstemp(prefix='pam_bench_end_', suffix='.json')
        os.close(fd)
        os.unlink(end_file)
        run_yaml = yaml.safe_dump(run_description(scene, params_file(settings), seed, layout),
                                  sort_keys=False)
        settings['recorder'] = dataclasses.replace(rec, run_yaml=run_yaml, end_file=end_file)
    if scene.faults and not wallclock:
        raise LayoutError(f'scene {scene.name} injects faults: they run on the wall clock '
                         '(--wallclock)')
    if live is not None:
        if netns:
            raise LayoutError('the live view runs on this host: drop --netns or --live')
        if not live.topics:
            live = dataclasses.replace(live, topics=live_topics(settings))
    with live_view(live, domain_id, quiet):
        if wallclock:
            from pam_bench.bringup.wallclock import run_wallclock
            return run_wallclock(scene, settings, domain_id, quiet, device_processes,
                                 devices_only)
        if one_process:
            from pam_bench.bringup.composed import run_composed
            return run_composed(scene, settings, domain_id, quiet)
        from pam_bench.bringup.processes import run_processes
        return run_processes(scene, settings, domain_id, quiet, netns)
