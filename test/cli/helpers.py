"""Run ``pam-bench`` in this process and see what a user sees: exit code, stdout, stderr."""

from __future__ import annotations

import contextlib
import hashlib
import io
import os
import pathlib
import signal


def cli(*args: str) -> tuple[int, str, str]:
    """``pam-bench ARGS``: (exit code, stdout, stderr). A traceback (an exception that is not
    a user error) propagates and fails the test; argparse's exit is an exit code too."""
    from pam_bench.cli.main import main
    handlers = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    out, err = io.StringIO(), io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main([str(a) for a in args])
            except SystemExit as exc:
                code = int(exc.code or 0)
    finally:
        for s, h in handlers.items():
            signal.signal(s, h)
    return code, out.getvalue(), err.getvalue()


def one_line_error(code: int, err: str) -> str:
    """The one error line of a failed verb (asserts there is exactly one, and no traceback)."""
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code != 0, err
    assert 'Traceback' not in err, err
    assert len(lines) == 1, err
    return lines[0]


def tree_digest(path: pathlib.Path) -> str:
    """One SHA-256 over every file below ``path`` (names and bytes): unchanged or not."""
    h = hashlib.sha256()
    for root, dirs, files in sorted(os.walk(path)):
        dirs.sort()
        for f in sorted(files):
            p = pathlib.Path(root) / f
            h.update(str(p.relative_to(path)).encode())
            h.update(p.read_bytes())
    return h.hexdigest()
