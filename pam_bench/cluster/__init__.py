"""Where runs fan out: Dask, a local cluster by default, a running one by its address."""

from __future__ import annotations

__all__ = ['errors', 'layer', 'loopback']
