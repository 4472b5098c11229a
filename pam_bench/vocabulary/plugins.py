"""Plug-ins: what a lab adds without editing pam_bench, found the Python way (entry points).

A package that declares entry points in one of ``GROUPS`` (its ``pyproject.toml``:
``[project.entry-points."pam_bench.muscle_laws"] my_law = "my_pkg.laws:LAW"``) is found by
``importlib.metadata`` once installed beside pam_bench. ``discover`` loads a group: every
entry point's object, its name and the distribution it comes from; one that does not load is
kept with the one-line reason (``pam-bench plugins`` lists it, the rest still work).
"""

from __future__ import annotations

import dataclasses
import functools
from importlib import metadata
from typing import Any

__all__ = ['GROUPS', 'Plugin', 'discover', 'plugin']

GROUPS = {'pam_bench.muscle_laws': 'static force law (models.laws.base.ForceLaw)',
          'pam_bench.controllers': 'torque-servo controller (control.plugins.Controller)'}
"""The entry-point groups pam_bench reads, with what each object must be."""


@dataclasses.dataclass(frozen=True)
class Plugin:
    """One entry point: its group, name, the distribution that declares it, the object it
    names (None when it did not load) and why it did not."""

    group: str
    name: str
    package: str
    obj: Any
    error: str = ''


@functools.cache
def _installed() -> Any:
    """Every entry point installed here, read once (``select``-able by group): each read goes
    through the metadata of every distribution of the environment (about 12 ms here), and a
    run looks up two groups."""
    return metadata.entry_points()


@functools.cache
def discover(group: str) -> tuple[Plugin, ...]:
    """Every plug-in of ``group`` installed here, by name (a plug-in that raises on loading
    is kept with its error, not raised)."""
    out = []
    for ep in sorted(_installed().select(group=group), key=lambda e: e.name):
        package = ep.dist.name if ep.dist is not None else '?'
        try:
            obj = ep.load()
        except Exception as exc:  # noqa: BLE001 - a lab's package: said, never fatal
            out.append(Plugin(group, ep.name, package, None,
                              f'{type(exc).__name__}: {str(exc).splitlines()[0][:200]}'
                              if str(exc) else type(exc).__name__))
            continue
        out.append(Plugin(group, ep.name, package, obj))
    return tuple(out)


def plugin(group: str, name: str) -> Plugin | None:
    """The plug-in called ``name`` in ``group``, or None."""
    return next((p for p in discover(group) if p.name == name), None)
