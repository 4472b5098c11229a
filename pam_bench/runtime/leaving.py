"""How a bench process ends once its work is done: output flushed, then ``os._exit``, without
the interpreter's module teardown or the C++ libraries' static destructors.

Those destructors cost and risk more than they do for a process that has closed what it
opened: Fast DDS's participant factory sleeps 100 ms in its destructor whatever is left, and
after a peer process was killed they were seen to corrupt the heap and abort a survivor whose
work was done (docs/long_runs.md, "The demo's start and end").
"""

from __future__ import annotations

import atexit
import contextlib
import logging
import os
import sys
import threading
from typing import NoReturn

__all__ = ['leave']


def leave(code: int, exit_handlers: bool = False) -> NoReturn:
    """End the process with ``code`` (module docstring). With ``exit_handlers`` (a command,
    which may have started Dask, worker processes or temporary folders) Python's ``atexit``
    handlers run first, and while a thread that is not a daemon still runs the process exits as
    Python exits, waiting for it, as it does under a profiler or a tracer (``python -m
    cProfile``, coverage), which write their results as Python exits; a node's process only
    shuts its logging down."""
    if exit_handlers:
        main = threading.main_thread()
        if any(t.is_alive() and not t.daemon and t is not main
               for t in threading.enumerate()) or sys.getprofile() or sys.gettrace():
            sys.exit(code)
        atexit._run_exitfuncs()
    else:
        logging.shutdown()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):    # a closed pipe: nothing more can be said
            stream.flush()
    os._exit(code)
