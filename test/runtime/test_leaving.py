"""How a bench process ends (``runtime.leaving.leave``): its exit code, its output flushed,
Python's exit handlers run for a command and not for a node, a running thread waited for."""

from __future__ import annotations

import pathlib
import subprocess
import sys
import textwrap

import pytest

SCRIPT = textwrap.dedent("""
    import atexit, pathlib, sys, threading, time
    from pam_bench.runtime.leaving import leave
    out = pathlib.Path(sys.argv[1])
    atexit.register(lambda: (out / 'atexit').write_text('ran'))
    if sys.argv[3] == 'thread':
        threading.Thread(target=lambda: (time.sleep(0.3),
                                         (out / 'thread').write_text('done'))).start()
    sys.stdout.write('said, unflushed')
    leave(3, exit_handlers=sys.argv[2] == 'command')
""")


@pytest.mark.parametrize('kind, thread, handlers', [
    ('command', 'none', True),       # Dask's, multiprocessing's, temporary folders' hooks run
    ('node', 'none', False),         # a node's process: only its logging is shut down
    ('command', 'thread', True),     # a thread still running: Python's own exit waits for it
])
def test_a_process_leaves_with_its_code_and_its_output(tmp_path: pathlib.Path, kind: str,
                                                       thread: str, handlers: bool) -> None:
    done = subprocess.run([sys.executable, '-c', SCRIPT, str(tmp_path), kind, thread],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 3, done.stderr
    assert done.stdout == 'said, unflushed'
    assert (tmp_path / 'atexit').exists() == handlers
    if thread == 'thread':
        assert (tmp_path / 'thread').read_text() == 'done'


def test_under_a_profiler_a_command_exits_as_python_does(tmp_path: pathlib.Path) -> None:
    """``python -m cProfile -o FILE``: the profile is written as Python exits (with
    ``os._exit`` it never was)."""
    script = tmp_path / 'cmd.py'
    script.write_text(SCRIPT)
    prof = tmp_path / 'out.prof'
    done = subprocess.run([sys.executable, '-m', 'cProfile', '-o', str(prof), str(script),
                           str(tmp_path), 'command', 'none'], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 0, done.stderr    # cProfile's runner takes the SystemExit
    assert prof.stat().st_size > 0 and (tmp_path / 'atexit').exists()
