"""Errors of the command line, and the one place that maps every package error to an exit code.

A verb raises; ``exit_code`` turns what it raised into one line on stderr and the exit code:
2 for anything the user can fix by changing the input (a bad or misspelt key, a broken bag, a
missing file, a wrong combination of flags), 130 for Ctrl-C, 141 for a closed pipe.
"""

from __future__ import annotations

import os
import sys

from pam_bench.analysis.errors import BagError, ExtractError
from pam_bench.benchmarks.errors import UsageError as StudyUsageError
from pam_bench.bringup.errors import LayoutError
from pam_bench.config.errors import ConfigError
from pam_bench.live.errors import LiveViewError
from pam_bench.models.errors import ModelError

__all__ = ['UsageError', 'USER_ERRORS', 'exit_code']


class UsageError(ValueError):
    """The command line asks for something it cannot do (the message says what instead)."""


USER_ERRORS = (UsageError, StudyUsageError, LayoutError, ConfigError, ModelError, BagError,
               ExtractError, FileNotFoundError, FileExistsError, NotADirectoryError,
               IsADirectoryError, PermissionError, LiveViewError)
"""What a user's input can cause: one line and exit code 2, never a traceback."""


def exit_code(exc: BaseException) -> int:
    """The exit code for ``exc``, its one line written to stderr.

    Raises:
        BaseException: ``exc`` itself when it is not an error of the user's input (a bug
            should show its traceback).
    """
    if isinstance(exc, KeyboardInterrupt):
        print('interrupted: nodes stopped, bag closed', file=sys.stderr)
        return 130
    if isinstance(exc, BrokenPipeError):     # `pam-bench ... | head`: the reader has gone
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    if isinstance(exc, USER_ERRORS):
        text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        print(f'error: {text}', file=sys.stderr)
        return 2
    raise exc
