"""The zoo: every static force law, in the order reports list them, and a lab's plug-in laws.

The built-in laws are ``FORCE_LAWS``; ``all_laws`` adds every law a package installed beside
pam_bench declares in the entry-point group ``pam_bench.muscle_laws`` (``vocabulary.plugins``),
after the built-ins. Extraction's law zoo, truth, the twin, the nodes and ``calibrate --law``
all take their laws from here.
"""

from __future__ import annotations

import functools
import re

import numpy as np

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
from pam_bench.vocabulary.plugins import Plugin, discover

__all__ = ['FORCE_LAWS', 'force_law', 'all_laws', 'problem', 'unusable', 'GROUP']

FORCE_LAWS: tuple[ForceLaw, ...] = (
    chou_hannaford.LAW, tondu_lopez.LAW, kerscher.LAW, kang.LAW, sarosi.LAW, al_ibadi.LAW,
    al_ibadi.TANGENT, straight_fibre.LAW, bench_mckibben.LAW)
GROUP = 'pam_bench.muscle_laws'
NAME = re.compile(r'[a-z][a-z0-9_]*')


@functools.lru_cache(maxsize=1)
def all_laws() -> tuple[ForceLaw, ...]:
    """The built-in laws, then every plug-in law that is usable (``unusable``: one that is
    not is left out here; ``pam-bench plugins`` says why)."""
    extra = [p.obj for p in discover(GROUP) if not unusable(p)]
    return FORCE_LAWS + tuple(extra)


def unusable(p: Plugin) -> str:
    """Why the law plug-in ``p`` cannot run ('' when it can): it does not load, is not a
    ``ForceLaw`` of a free name, or does not give finite forces of the inputs' shape at its
    default parameters (4 and 600 kPa, 0 and 20 mm, l0 = 0.2 m)."""
    why = p.error or problem(p.obj)
    if why:
        return why
    law: ForceLaw = p.obj
    pressure, contraction = np.array([4e5, 6e5, 6e5]), np.array([0.0, 0.0, 0.02])
    try:
        force = np.asarray(law.law(np.asarray(law.start, dtype=float), pressure, contraction,
                                   0.2), dtype=float)
    except Exception as exc:  # noqa: BLE001 - a lab's law: whatever it raises, named
        text = str(exc).splitlines()[0][:160] if str(exc) else ''
        return f'fails at its default parameters: {type(exc).__name__}: {text}'
    if force.shape != pressure.shape:
        return f'gives forces of shape {force.shape} for inputs of shape {pressure.shape}'
    if not np.isfinite(force).all():
        return 'gives forces that are not finite at its default parameters'
    return ''


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
    broken = next((p for p in discover(GROUP) if getattr(p.obj, 'name', p.name) == name
                   or p.name == name), None)
    if broken is not None:
        raise ParameterError(f'force law {name!r}: its plug-in (package {broken.package}) '
                             f'cannot be used: {unusable(broken)}')
    names = [m.name for m in all_laws()]
    raise ParameterError(f'unknown force law {name!r} ({hint(name, names)})')
