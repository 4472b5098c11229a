"""Importing a third-party package without one of the modules it imports for a feature the
bench never uses (numba without ``coverage``, ``rosidl_generator_py`` without its code
generator): the module stands as absent while the package loads, and is put back at once."""

from __future__ import annotations

import importlib
import sys
from typing import Any

__all__ = ['import_without']


def import_without(name: str, held: str) -> Any:
    """Import module ``name`` with module ``held`` standing as absent (``sys.modules[held] =
    None``: an ``import held`` inside raises ImportError, which the package handles as the
    feature being unavailable), then take the stand-in back, so a later import of ``held``
    works. Nothing is held when ``held`` is already imported; a ``name`` already imported is
    returned as it is.

    Returns:
        The module ``name``.

    Raises:
        ImportError: ``name`` is not installed, or does not load without ``held``.
    """
    hold = held not in sys.modules
    if hold:
        sys.modules[held] = None  # type: ignore[assignment]
    try:
        return importlib.import_module(name)
    finally:
        if hold and held in sys.modules and sys.modules[held] is None:
            del sys.modules[held]
