"""The live view beside a run: its process started before the run and stopped after it.

``live_topics`` is what it serves: the topics the scene's recorder records, without ``/clock``
and the ``/sim/`` ground truth (what a real bench has). ``live_view`` starts
``pam_bench.nodes.live_view`` in its own process on the run's domain, waits until its server
is up (a port in use is one ``LiveViewError``) and stops it when the run ends, whatever the
layout: the view subscribes on DDS as any outside tool does.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import signal
import subprocess
import sys
import tempfile
import threading
from collections.abc import Iterator
from typing import Any

from pam_bench.bringup.common import die_with_parent, ns_args, ros_env, write_params_file
from pam_bench.config.settings import LiveViewSettings
from pam_bench.live.errors import LiveViewError

__all__ = ['live_topics', 'live_view', 'with_port']

START_TIMEOUT_S = 30.0


def live_topics(settings: dict[str, Any]) -> list[str]:
    """``topic:type`` of every recorded topic a real bench has (from the recorder's
    settings).

    Raises:
        LiveViewError: the scene has no recorder, so no list of its topics.
    """
    rec = settings.get('recorder')
    if rec is None:
        raise LiveViewError('live view: the scene has no recorder, whose topics it serves')
    return [e for e in list(rec.step_topics) + list(rec.event_topics)
            if e and not e.startswith('/clock:') and not e.startswith('/sim/')]


@contextlib.contextmanager
def live_view(live: LiveViewSettings | None, domain_id: int | None = None,
              quiet: bool = False, namespace: str = '') -> Iterator[subprocess.Popen | None]:
    """Run the live view with ``live`` (None: no live view) for the ``with`` block, on the
    bench in ``namespace`` ('': the root).

    Raises:
        LiveViewError: it did not start (port in use, bad address): its one line.
    """
    if live is None:
        yield None
        return
    with tempfile.TemporaryDirectory(prefix='pam_bench_live_') as tmp:
        pfile = os.path.join(tmp, 'live.yaml')
        write_params_file({'live_view': live}, pfile)
        proc = subprocess.Popen([sys.executable, '-m', 'pam_bench.nodes.live_view',
                                 '--ros-args', '-r', '__node:=live_view', '--params-file',
                                 pfile, *ns_args(namespace)], env=ros_env(domain_id),
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                preexec_fn=die_with_parent)
        try:
            _wait_ready(proc, quiet)
            yield proc
        finally:
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)     # as ``common.stop_processes``
                try:
                    proc.wait(timeout=10.0)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait()


def _wait_ready(proc: subprocess.Popen, quiet: bool) -> None:
    from pam_bench.nodes.live_view import READY
    assert proc.stdout is not None
    lines: list[str] = []
    timer = threading.Timer(START_TIMEOUT_S, proc.kill)
    timer.start()
    try:
        for line in proc.stdout:
            lines.append(line.rstrip())
            if line.startswith(READY):
                if not quiet:
                    print(line, end='', flush=True)
                threading.Thread(target=_drain, args=(proc.stdout,), daemon=True).start()
                return
    finally:
        timer.cancel()
    proc.wait()
    why = next((ln.split('error: ', 1)[1] for ln in lines if 'error: ' in ln),
               lines[-1] if lines else 'it exited')
    raise LiveViewError(why)


def _drain(stream: Any) -> None:
    for _ in stream:
        pass


def with_port(live: LiveViewSettings, port: int | None, host: str | None,
              rate_hz: float | None, topics: list[str]) -> LiveViewSettings:
    """``live`` with the CLI's choices over it."""
    out = dataclasses.replace(live, topics=topics)
    if port is not None:
        out = dataclasses.replace(out, port=port)
    if host is not None:
        out = dataclasses.replace(out, host=host)
    if rate_hz is not None:
        out = dataclasses.replace(out, max_rate_hz=rate_hz)
    return out
