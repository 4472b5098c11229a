"""Errors of the command line, and the one place that maps errors to exit codes.

A verb raises; ``exit_code`` turns what it raised into one line on stderr and the exit code:
every package error (``vocabulary.errors.PamBenchError``: a bad or misspelt key, a broken bag,
an output it may not write, an unreachable cluster) exits with its ``exit_code`` (2: the user
can fix the input), as do the file system's own errors about a path the user named; 130 for
Ctrl-C, 141 for a closed pipe. Anything else is a bug and shows its traceback.
"""

from __future__ import annotations

import os
import sys

from pam_bench.vocabulary.errors import PamBenchError

__all__ = ['UsageError', 'USER_ERRORS', 'exit_code']


class UsageError(PamBenchError, ValueError):
    """The command line asks for something it cannot do (the message says what instead)."""


USER_ERRORS = (PamBenchError, FileNotFoundError, FileExistsError, NotADirectoryError,
               IsADirectoryError, PermissionError)
"""What a user's input can cause: one line and an exit code, never a traceback."""


def exit_code(exc: BaseException) -> int:
    """The exit code for ``exc``, its one line written to stderr.

    Raises:
        BaseException: ``exc`` itself when it is not an error of the user's input (a bug
            should show its traceback).
    """
    if isinstance(exc, KeyboardInterrupt):
        print('interrupted', file=sys.stderr)
        return 130
    if isinstance(exc, BrokenPipeError):     # `pam-bench ... | head`: the reader has gone
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    if isinstance(exc, USER_ERRORS):
        text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        print(f'error: {text}', file=sys.stderr)
        return exc.exit_code if isinstance(exc, PamBenchError) else 2
    raise exc
