"""The zoo: every static force law, in the order reports list them, and a lab's plug-in laws.

The built-in laws are ``FORCE_LAWS``; ``all_laws`` adds every law a package installed beside
pam_bench declares in the entry-point group ``pam_bench.muscle_laws`` (``vocabulary.plugins``),
after the built-ins. Extraction's law zoo, truth, the twin, the nodes and ``calibrate --law``
all take their laws from here.
"""

from __future__ import annotations

import functools
import re

from pam_bench.models.laws import (
    al_ibadi,
    bench_mckibben,
    chou_hannaford,
    kang,
    kerscher,
    sarosi,
    straight_fibre,
    tondu_lopez,
)
from pam_bench.models.laws.base import ForceLaw
from pam_bench.vocabulary.errors import ParameterError
from pam_bench.vocabulary.params import hint
from pam_bench.vocabulary.plugins import discover

__all__ = ['FORCE_LAWS', 'force_law', 'all_laws', 'problem', 'GROUP']

FORCE_LAWS: tuple[ForceLaw, ...] = (
    chou_hannaford.LAW, tondu_lopez.LAW, kerscher.LAW, kang.LAW, sarosi.LAW, al_ibadi.LAW,
    al_ibadi.TANGENT, straight_fibre.LAW, bench_mckibben.LAW)
GROUP = 'pam_bench.muscle_laws'
NAME = re.compile(r'[a-z][a-z0-9_]*')


@functools.lru_cache(maxsize=1)
def all_laws() -> tuple[ForceLaw, ...]:
    """The built-in laws, then every plug-in law that loads and is a ``ForceLaw`` whose name
    no built-in takes (one that is not is left out here; ``pam-bench plugins`` says why)."""
    taken = {law.name for law in FORCE_LAWS}
    extra = [p.obj for p in discover(GROUP) if not problem(p.obj, taken)]
    return FORCE_LAWS + tuple(extra)


def problem(obj: object, taken: set[str] | None = None) -> str:
    """Why a plug-in's object cannot be a force law of the bench ('' when it can)."""
    if not isinstance(obj, ForceLaw):
        return f'not a ForceLaw: {type(obj).__name__}'
    if not NAME.fullmatch(obj.name):
        return f'its name {obj.name!r} is not a settings name (a-z, 0-9, _)'
    if obj.name in (taken if taken is not None else {law.name for law in FORCE_LAWS}):
        return f"its name {obj.name!r} is a built-in law's"
    return ''


def force_law(name: str) -> ForceLaw:
    """The law called ``name`` (built-in or plug-in).

    Raises:
        ParameterError: no such law (names the nearest).
    """
    for law in all_laws():
        if law.name == name:
            return law
    names = [m.name for m in all_laws()]
    raise ParameterError(f'unknown force law {name!r} ({hint(name, names)})')
