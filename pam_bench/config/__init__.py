"""Configuration: where config/ and msg_defs/ are, strict YAML, scenes, protocols, topics."""

from __future__ import annotations

__all__ = ['drivers', 'paths', 'protocols', 'scene', 'topics', 'yaml_io']
