"""The zoo: every static force law, in the order reports list them."""

from __future__ import annotations

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

__all__ = ['FORCE_LAWS', 'force_law']

FORCE_LAWS: tuple[ForceLaw, ...] = (
    chou_hannaford.LAW, tondu_lopez.LAW, kerscher.LAW, kang.LAW, sarosi.LAW, al_ibadi.LAW,
    al_ibadi.TANGENT, straight_fibre.LAW, bench_mckibben.LAW)


def force_law(name: str) -> ForceLaw:
    """The law called ``name``.

    Raises:
        ParameterError: no such law (names the nearest).
    """
    for law in FORCE_LAWS:
        if law.name == name:
            return law
    names = [m.name for m in FORCE_LAWS]
    raise ParameterError(f'unknown force law {name!r} ({hint(name, names)})')
