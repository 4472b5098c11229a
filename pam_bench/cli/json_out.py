"""What ``--json`` prints: strict JSON (RFC 8259), which every parser reads.

Python's ``json`` writes NaN and Infinity for non-finite floats; JavaScript's ``JSON.parse``
and other strict parsers refuse them. A value that is not finite (a standard error the data
leave undefined, a profile side a bound ended) is written as null.
"""

from __future__ import annotations

import json
import math
from typing import Any

__all__ = ['dumps']


def _finite(value: Any) -> Any:
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    if hasattr(value, 'item') and hasattr(value, 'dtype') and getattr(value, 'ndim', 1) == 0:
        return _finite(value.item())                  # a numpy scalar
    return value


def dumps(value: Any, indent: int | None = 2) -> str:
    """``value`` as strict JSON: non-finite floats as null, what JSON cannot hold as its
    ``str``."""
    return json.dumps(_finite(value), indent=indent, default=str, allow_nan=False)
