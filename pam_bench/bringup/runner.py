"""Bring a scene up, run it, shut everything down, in the layout asked for.

``run_scene`` resolves the scene's settings (``config.scene.Scene.settings``), describes the run
for the bag (``provenance``), and hands it to a layout: ``composed`` (every node in one
process), ``processes`` (one process per node, or two hosts with ``netns``) or ``wallclock``
(a real bench's layout on the wall clock). ``common`` is what they share; ``domains`` keeps two
runs in one ROS domain apart.
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import os
import tempfile

import yaml

from pam_bench.bringup.common import RunResult, ros_env, write_params_file
from pam_bench.bringup.domains import private_domain, shared_domain, wanted_domain
from pam_bench.bringup.errors import LayoutError
from pam_bench.bringup.live import live_topics, live_view
from pam_bench.config.scene import Scene, params_file
from pam_bench.vocabulary.run import Layout, RunOptions

__all__ = ['RunResult', 'ros_env', 'run_scene', 'write_params_file']


def run_scene(scene: Scene, out_dir: str, options: RunOptions | None = None) -> RunResult:
    """Run ``scene``, recording into ``out_dir``, as ``options`` say; return the clock's summary.

    A lock-step run is composed in this process by default (``Layout.COMPOSED``;
    ``Layout.PROCESSES``: one process per node, as beside drivers; ``netns`` implies it).
    ``Layout.WALL_CLOCK`` runs as a real bench; with ``devices_only`` only the simulated
    devices run, until Ctrl-C: a bench to point a lab's own controllers or ``check-drivers``
    at. ``settings`` (node -> settings: the ones a bag recorded, ``--replay``) replace the
    scene's. ``netns`` (device namespace, other namespace) runs the simulated devices and the
    other nodes in two network namespaces, as on two hosts, with DDS discovery on their subnet.
    ``live`` serves the recorded topics to Foxglove during the run (``bringup.live``; its
    ``topics`` filled from the recorder's when empty).

    Raises:
        LiveViewError: the live view cannot start (its port is taken).
        LayoutError: the scene and the options ask for a layout that cannot run.
        DomainInUseError: a wall-clock run would start a node another run has in its domain
            and namespace, or a lock-step run holds the domain.
    """
    o = options or RunOptions()
    layout = Layout.PROCESSES if o.netns and o.layout is Layout.COMPOSED else o.layout
    settings = (copy.deepcopy(o.settings) if o.settings
                else scene.settings(out_dir, o.seed, o.realtime))
    if 'recorder' in settings:
        from pam_bench.bringup.provenance import run_description
        rec = dataclasses.replace(settings['recorder'], out_dir=out_dir, run_yaml='',
                                  end_file='')
        settings['recorder'] = rec
        fd, end_file = tempfile.mkstemp(prefix='pam_bench_end_', suffix='.json')
        os.close(fd)
        os.unlink(end_file)
        run_yaml = yaml.safe_dump(run_description(scene, params_file(settings), o.seed,
                                                  layout.value), sort_keys=False)
        settings['recorder'] = dataclasses.replace(rec, run_yaml=run_yaml, end_file=end_file)
    from pam_bench.sim.faults import BUS_KINDS
    if any(f.kind in BUS_KINDS for f in scene.faults) and not o.buses:
        raise LayoutError(f'scene {scene.name} injects faults into the buses: run it with '
                          '--wallclock --buses')
    if scene.faults and layout is not Layout.WALL_CLOCK:
        raise LayoutError(f'scene {scene.name} injects faults: they run on the wall clock '
                          '(--wallclock)')
    if o.buses and layout is not Layout.WALL_CLOCK:
        raise LayoutError('--buses runs the bench on the wall clock: add --wallclock')
    if o.namespace and layout is not Layout.WALL_CLOCK:
        raise LayoutError('--namespace runs the nodes on the wall clock: add --wallclock')
    if o.netns and layout is Layout.WALL_CLOCK:
        raise LayoutError('--netns runs lock-step: drop --wallclock or --netns')
    if o.external and layout is not Layout.WALL_CLOCK:
        raise LayoutError('--external runs beside real devices on the wall clock: add '
                          '--wallclock')
    from pam_bench.bringup.external import check_external
    check_external(scene.name, scene.nodes, o.external, o.buses)
    live = o.live
    if live is not None:
        if o.netns:
            raise LayoutError('the live view runs on this host: drop --netns or --live')
        if not live.topics:
            live = dataclasses.replace(live, topics=live_topics(settings))
    wanted = wanted_domain(o.domain_id)
    # lock-step: the domain alone; wall clock: shared, its node names leased (bringup.domains)
    if layout.lockstep:
        lease = private_domain(wanted, o.quiet)
    else:
        from pam_bench.bringup.wallclock import wall_nodes
        lease = shared_domain(wanted, o.namespace, wall_nodes(scene, o.devices_only, o.buses,
                                                              o.external))
    try:
        with lease as domain, live_view(live, domain, o.quiet, o.namespace):
            if layout is Layout.WALL_CLOCK:
                from pam_bench.bringup.wallclock import run_wallclock
                return run_wallclock(scene, settings, domain, o.quiet,
                                     o.device_processes, o.devices_only, o.namespace, o.buses,
                                     o.external)
            if layout is Layout.COMPOSED:
                from pam_bench.bringup.composed import run_composed
                return run_composed(scene, settings, domain, o.quiet)
            from pam_bench.bringup.processes import run_processes
            return run_processes(scene, settings, domain, o.quiet, o.netns)
    finally:                # the end state is the recorder's to read, then nobody's
        end = settings['recorder'].end_file if 'recorder' in settings else ''
        if end:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(end)
