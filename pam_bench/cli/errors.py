"""Errors of the command line, and the one place that maps errors to exit codes.

A verb raises; ``exit_code`` turns what it raised into one line on stderr and the exit code:
every package error (``vocabulary.errors.PamBenchError``: a bad or misspelt key, a broken bag,
an output it may not write, an unreachable cluster) exits with its ``exit_code`` (2: the user
can fix the input), as do the file system's own errors about a path the user named and the
limits of the machine or the user's shell (a full disk, ``ulimit -f``, ``-n`` or ``-v``: exit
code 1, with the bag closed or repairable); 130 for Ctrl-C, 143 for SIGTERM, 141 for a closed
pipe. Anything else is a bug and shows its traceback.
"""

from __future__ import annotations

import errno
import os
import sys

from pam_bench.vocabulary.errors import PamBenchError

__all__ = ['UsageError', 'USER_ERRORS', 'LIMITS', 'MIN_OPEN_FILES', 'Terminated',
           'check_limits', 'exit_code']


class UsageError(PamBenchError, ValueError):
    """The command line asks for something it cannot do (the message says what instead)."""


USER_ERRORS = (PamBenchError, FileNotFoundError, FileExistsError, NotADirectoryError,
               IsADirectoryError, PermissionError)
"""What a user's input can cause: one line and an exit code, never a traceback."""


LIMITS = {errno.EFBIG: 'the file-size limit (ulimit -f)',
          errno.ENOSPC: 'no space left on the device',
          errno.EDQUOT: 'the disk quota',
          errno.EMFILE: 'the open-file limit (ulimit -n)',
          errno.ENFILE: "the system's open-file limit",
          errno.ENOMEM: 'the memory limit (ulimit -v)',
          errno.ENAMETOOLONG: 'a file name too long for the file system',
          errno.EROFS: 'a read-only file system',
          errno.ELOOP: 'a loop of symbolic links'}
"""An ``OSError`` that the machine or the shell's limits raise, and how to say it."""


MIN_OPEN_FILES = 64
"""The fewest file descriptors a verb starts with: DDS takes a dozen per process before a node
has a topic (``check_limits``)."""


def check_limits() -> None:
    """Check, before any verb starts, the limits it cannot do without.

    Raises:
        UsageError: the open-file limit is below ``MIN_OPEN_FILES`` (one line, what to do).
    """
    import resource
    soft, _ = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft != resource.RLIM_INFINITY and soft < MIN_OPEN_FILES:
        raise UsageError(f'the open-file limit is {soft} (ulimit -n); pam-bench needs at '
                         f'least {MIN_OPEN_FILES}: raise it (ulimit -n 1024)')


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where Ctrl-C would be (every verb stops the same way; exit 143)."""


def exit_code(exc: BaseException) -> int:
    """The exit code for ``exc``, its one line written to stderr.

    Raises:
        BaseException: ``exc`` itself when it is not an error of the user's input (a bug
            should show its traceback).
    """
    if isinstance(exc, Terminated):
        print('terminated', file=sys.stderr)
        return 143
    if isinstance(exc, KeyboardInterrupt):
        print('interrupted', file=sys.stderr)
        return 130
    if isinstance(exc, MemoryError):
        print("error: out of memory (the memory limit, ulimit -v, or the machine's)",
              file=sys.stderr)
        return 1
    if isinstance(exc, RuntimeError) and 'Too many open files' in str(exc):   # rcl's words
        print(f'error: {LIMITS[errno.EMFILE]} was reached ({str(exc).splitlines()[0][:120]})',
              file=sys.stderr)
        return 1
    if isinstance(exc, OSError) and exc.errno in LIMITS and not isinstance(exc, PamBenchError):
        where = f': {exc.filename}' if exc.filename else ''
        print(f'error: {LIMITS[exc.errno]} was reached{where} ({exc.strerror or exc})',
              file=sys.stderr)
        return 1
    if isinstance(exc, BrokenPipeError):     # `pam-bench ... | head`: the reader has gone
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    if isinstance(exc, USER_ERRORS):
        text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        print(f'error: {text}', file=sys.stderr)
        return exc.exit_code if isinstance(exc, PamBenchError) else 2
    raise exc
