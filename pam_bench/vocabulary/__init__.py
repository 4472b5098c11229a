"""The words every room uses: the settings framework, the error base, the rule for outputs."""

from __future__ import annotations

__all__ = ['errors', 'imports', 'outputs', 'params', 'run', 'yaml_io']
