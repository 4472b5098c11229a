"""Opt-in profile of a node process: ``PAM_BENCH_PROFILE=DIR`` writes DIR/NAME.prof (cProfile)
when the process ends; ``benchmarks.profile`` reads them and splits the time by cause."""

from __future__ import annotations

import contextlib
import cProfile
import os
import pathlib
from collections.abc import Iterator

__all__ = ['ENV', 'profiled']

ENV = 'PAM_BENCH_PROFILE'


@contextlib.contextmanager
def profiled(name: str) -> Iterator[None]:
    """Profile the block into ``$PAM_BENCH_PROFILE/<name>.prof`` when the variable is set."""
    out = os.environ.get(ENV)
    if not out:
        yield
        return
    prof = cProfile.Profile()
    prof.enable()
    try:
        yield
    finally:
        prof.disable()
        path = pathlib.Path(out)
        path.mkdir(parents=True, exist_ok=True)
        prof.dump_stats(str(path / f'{name}.prof'))
