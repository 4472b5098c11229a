"""Configuration: where config/ and msg_defs/ are, strict YAML, scenes, protocols, topics, DDS."""

from __future__ import annotations

__all__ = ['dds', 'drivers', 'errors', 'executables', 'nodes', 'paths', 'protocols', 'scene',
           'settings', 'topics']
