"""Configuration: where config/ and msg_defs/ are, strict YAML, scenes, protocols, topics."""

from __future__ import annotations

__all__ = ['drivers', 'errors', 'executables', 'nodes', 'paths', 'protocols', 'scene', 'settings',
           'topics']
