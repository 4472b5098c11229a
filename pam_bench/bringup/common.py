"""What every layout of a run shares: its result, its environment, its params file, how a node
process is started and stopped, and how the recorder learns how the run ended.

Every run sets ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` and its own ``ROS_DOMAIN_ID`` (the
caller's when set, else one derived from the process id), so DDS stays on loopback and two
runs never see each other. Node processes are stopped with SIGTERM (SIGKILL after a timeout),
devices first and the recorder last, so the bag is always closed. A started node takes SIGTERM
as it takes Ctrl-C (``runtime.process.run_node``); one still importing its modules (a run that
ends in its first second: another clock in the domain) dies of it at once and quietly, where
SIGINT would print a KeyboardInterrupt traceback into the run's output.
"""

from __future__ import annotations

import dataclasses
import os
import pathlib
import signal
import subprocess
import sys
from typing import Any

import yaml

from pam_bench.config.dds import discovery_profile_env
from pam_bench.config.nodes import NODES
from pam_bench.sim.lockstep import RunSummary

__all__ = ['RunResult', 'RUN_ENV', 'ros_env',
           'clean_shared_memory', 'die_with_parent', 'batch_child', 'result_of', 'node_error',
           'write_params_file', 'ros_params', 'node_cmd', 'ns_args', 'write_end_state',
           'copy_lines', 'stop_processes']


@dataclasses.dataclass
class RunResult:
    """Outcome of a run: exit code, steps, sim and wall seconds, lock-step rate (steps/s)."""

    code: int
    steps: int = 0
    sim_s: float = 0.0
    wall_s: float = 0.0
    rate: float = 0.0
    summary: str = ''
    # wall clock: per node; one process: 'deliveries' (messages to in-process subscriptions)
    stats: dict[str, Any] = dataclasses.field(default_factory=dict)


RUN_ENV = 'PAM_BENCH_RUN'
"""Set in every process a run starts: the process id of the run (its identity, whatever
domain it leased; tools and tests find a run's processes by it)."""


def ros_env(domain_id: int | None = None, discovery: str = 'LOCALHOST') -> dict[str, str]:
    """Environment for ROS processes of one run: loopback discovery (``SUBNET`` across
    network namespaces: ``netns``), a private domain, the bench's discovery profile unless
    the caller has one (``discovery_profile_env``)."""
    env = dict(os.environ)
    discovery_profile_env(env)
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = discovery
    if domain_id is None:
        domain_id = int(env.get('ROS_DOMAIN_ID', '') or 1 + os.getpid() % 100)
    env['ROS_DOMAIN_ID'] = str(domain_id)
    env[RUN_ENV] = str(os.getpid())       # the run's identity: every process it starts
    env.setdefault('RCUTILS_COLORIZED_OUTPUT', '0')
    import resource
    size, _ = resource.getrlimit(resource.RLIMIT_FSIZE)
    if size != resource.RLIM_INFINITY:      # ulimit -f: Fast DDS's shared-memory segments
        env.setdefault('FASTDDS_BUILTIN_TRANSPORTS', 'UDPv4')   # are files; it fails loudly
    # One BLAS thread per node: many node processes share two cores, and BLAS thread pools
    # spinning against each other made a 4x4 matrix exponential 100x slower.
    for var in ('OPENBLAS_NUM_THREADS', 'OMP_NUM_THREADS', 'MKL_NUM_THREADS'):
        env[var] = '1'
    return env


def clean_shared_memory() -> str:
    """Remove the shared-memory segments and ports Fast DDS left behind processes that died
    (SIGKILL, a crash): ``fastdds shm clean`` touches only those whose owner is gone. Stale
    ones pile up in /dev/shm over many killed runs, and a writer may then stall on a dead
    reader's port (docs/long_runs.md, "Leaked shared memory and the wall-clock tests").
    Returns what it said ('' when the tool is not there or failed: best effort)."""
    import shutil
    tool = pathlib.Path(sys.executable).with_name('fastdds')
    exe = str(tool) if tool.exists() else shutil.which('fastdds')
    if exe is None:
        return ''
    try:
        res = subprocess.run([exe, 'shm', 'clean'], capture_output=True, text=True,
                             timeout=10.0)
    except (OSError, subprocess.SubprocessError):
        return ''
    return res.stdout.strip().replace('\n', '; ') if res.returncode == 0 else ''


def die_with_parent() -> None:
    """In a node process: get SIGTERM when the runner dies, even by SIGKILL (Linux)."""
    try:
        import ctypes
        ctypes.CDLL('libc.so.6', use_errno=True).prctl(1, signal.SIGTERM)   # PR_SET_PDEATHSIG
    except OSError:
        pass


def batch_child() -> None:
    """In a lock-step node process: ``die_with_parent``, and the SCHED_BATCH policy.

    A lock-step run is throughput work: no deadline, only the exchanges per second. With
    more node processes than cores, the default policy lets every message wake-up preempt the
    running process, and each preemption is a context switch the exchange pays for; SCHED_BATCH
    (Linux, no privilege needed) keeps the nice level and drops that wake-up preemption
    (docs/long_runs.md, "Lock-step processes under SCHED_BATCH"). Wall-clock runs keep
    the default policy (or their SCHED_FIFO control loop).
    """
    die_with_parent()
    try:
        os.sched_setscheduler(0, os.SCHED_BATCH, os.sched_param(0))
    except (AttributeError, OSError):
        pass


def result_of(summary: RunSummary | None, code: int) -> RunResult:
    """The ``RunResult`` of a clock summary (None: the run never got one) and exit code."""
    if summary is None:
        return RunResult(code)
    return RunResult(code, summary.steps, summary.sim_s, summary.wall_s, summary.rate,
                     summary.line())


def node_error(log: str) -> str:
    """The one-line error a node printed when it stopped (``runtime.process.run_node``), or ''."""
    for line in reversed(log.splitlines()):
        if ': error: ' in line:
            return line.strip()
    return ''


def ros_params(settings: dict[str, Any]) -> dict[str, Any]:
    """The settings as an rcl params file's mapping, keyed ``/**/NODE``: it applies to the node
    of that name in any namespace (``__ns``); values as ROS holds them (``runtime.params``)."""
    from pam_bench.runtime.params import ros_value
    from pam_bench.vocabulary.params import flat_infos, get_path
    out: dict[str, Any] = {}
    for name, st in settings.items():
        params: dict[str, Any] = {}
        for info in flat_infos(type(st)):
            here = params
            parts = info.name.split('.')
            for part in parts[:-1]:
                here = here.setdefault(part, {})
            here[parts[-1]] = ros_value(info, get_path(st, info.name))
        out[f'/**/{name}'] = {'ros__parameters': params}
    return out


def write_params_file(settings: dict[str, Any], path: str) -> None:
    """The settings as a ROS 2 params file (``ros_params``)."""
    with open(path, 'w', encoding='utf-8') as fh:
        yaml.safe_dump(ros_params(settings), fh)


def ns_args(namespace: str) -> list[str]:
    """The ROS arguments that put a node in ``namespace`` (none for the root)."""
    return ['-r', f'__ns:={namespace}'] if namespace.strip('/') else []


def node_cmd(name: str, pfile: str, namespace: str = '') -> list[str]:
    """The command line that starts node ``name`` with the params file ``pfile`` in
    ``namespace`` ('': the root)."""
    return [sys.executable, '-m', NODES[name].module, '--ros-args', '-r', f'__node:={name}',
            '--params-file', pfile, *ns_args(namespace)]


def write_end_state(settings: dict[str, Any], code: int | None) -> None:
    """Tell the recorder how the run ended (``provenance.write_end``) before it is stopped."""
    from pam_bench.bringup.provenance import write_end
    rec = settings.get('recorder')
    path = rec.end_file if rec is not None else ''
    try:
        write_end(path, code)
    except OSError as exc:
        sys.stderr.write(f'warning: end state not written: {exc}\n')


def copy_lines(src: Any, dst: Any) -> None:
    """Copy every line of ``src`` to ``dst`` (a node's output into the run's log)."""
    for line in src:
        dst.write(line)


def stop_processes(procs: dict[str, subprocess.Popen]) -> None:
    """SIGTERM the clock and the devices, then the recorder; SIGKILL after a timeout (module
    docstring)."""
    devices = [n for n in procs if n != 'recorder']
    groups = [devices] + ([['recorder']] if 'recorder' in procs else [])
    for group in groups:
        for n in group:
            if procs[n].poll() is None:
                procs[n].send_signal(signal.SIGTERM)
        for n in group:
            for sig, wait in ((None, 15.0), (signal.SIGKILL, 5.0)):
                if sig is not None and procs[n].poll() is None:
                    procs[n].send_signal(sig)
                try:
                    procs[n].wait(timeout=wait)
                    break
                except subprocess.TimeoutExpired:
                    continue
