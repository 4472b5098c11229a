"""Strict, bounded YAML: one ``InputError`` naming the file and the problem, never a hang.

Every YAML a user hands pam_bench (scenes, overlays, params files, protocols, sweeps, ``--set``
values, suspender and fault lists) is read here:

- at most ``MAX_BYTES`` of text (a 50 MB description, a file of a million keys: refused at
  once, the limit in the message);
- UTF-8 only (another encoding is one line, not a ``UnicodeDecodeError``);
- anchors and aliases allowed, but the document as aliases expand it holds at most
  ``MAX_NODES`` nodes (a "billion laughs" is refused before anything expands it);
- a key twice in one mapping is an error naming the key and its line (merge keys ``<<`` may
  be overridden, as YAML means them);
- numbers as YAML 1.2 reads them: ``1e4``, ``2e-3`` and ``1.0e5`` are floats (YAML 1.1, which
  PyYAML follows, needs a dot and a signed exponent and reads them as strings).
"""

from __future__ import annotations

import pathlib
import re
from typing import Any

import yaml

from pam_bench.vocabulary.errors import InputError, shorten

__all__ = ['read_yaml', 'read_text', 'parse_yaml', 'load_yaml', 'load_written',
           'MAX_BYTES', 'MAX_NODES']

MAX_BYTES = 1 << 20
"""Largest YAML text read, bytes (1 MiB: the largest config file of the bench is 10 kB)."""
MAX_NODES = 100_000
"""Most nodes a document may expand to through its aliases."""

_Base: Any = getattr(yaml, 'CSafeLoader', yaml.SafeLoader)


class _Refused(yaml.YAMLError):
    """What the strict loader refuses (its message is the user's line)."""


def _expanded(node: yaml.Node, memo: dict[int, int]) -> int:
    """Nodes of ``node`` with every alias expanded (each shared node counted once per use,
    computed once)."""
    key = id(node)
    if key in memo:
        return memo[key]
    memo[key] = MAX_NODES + 1          # a cycle (a recursive alias) counts as too large
    total = 1
    if isinstance(node, yaml.SequenceNode):
        for child in node.value:
            total += _expanded(child, memo)
            if total > MAX_NODES:
                break
    elif isinstance(node, yaml.MappingNode):
        for k, v in node.value:
            total += _expanded(k, memo) + _expanded(v, memo)
            if total > MAX_NODES:
                break
    memo[key] = total
    return total


class _StrictLoader(_Base):
    """The safe loader, with duplicate keys and alias bombs refused."""

    def construct_document(self, node: yaml.Node) -> Any:
        if _expanded(node, {}) > MAX_NODES:
            raise _Refused(f'its aliases expand to more than {MAX_NODES} nodes')
        return super().construct_document(node)

    def construct_mapping(self, node: yaml.Node, deep: bool = False) -> Any:
        if isinstance(node, yaml.MappingNode):
            seen: set[Any] = set()
            for key_node, _ in node.value:
                if key_node.tag == 'tag:yaml.org,2002:merge':
                    continue
                key = self.construct_object(key_node, deep=True)
                try:
                    duplicate = key in seen
                    seen.add(key)
                except TypeError:          # an unhashable key: the constructor says so
                    continue
                if duplicate:
                    raise _Refused(f'duplicate key {shorten(key)} (line '
                                   f'{key_node.start_mark.line + 1})')
        return super().construct_mapping(node, deep)


_FLOAT_1_2 = re.compile(r"""^(?:[-+]?[0-9][0-9_]*\.[0-9_]*(?:[eE][-+]?[0-9]+)?
    |[-+]?[0-9][0-9_]*[eE][-+]?[0-9]+
    |[-+]?\.[0-9][0-9_]*(?:[eE][-+]?[0-9]+)?
    |[-+]?\.(?:inf|Inf|INF)
    |\.(?:nan|NaN|NAN))$""", re.X)
"""YAML 1.2's core-schema floats (with PyYAML's underscores, as YAML 1.1 allowed them)."""
_StrictLoader.yaml_implicit_resolvers = {
    k: [(tag, rx) for tag, rx in v if tag != 'tag:yaml.org,2002:float']
    for k, v in _StrictLoader.yaml_implicit_resolvers.items()}
_StrictLoader.add_implicit_resolver('tag:yaml.org,2002:float', _FLOAT_1_2,
                                    list('-+0123456789.'))


def load_yaml(text: str, where: str) -> Any:
    """Parse YAML text strictly (module docstring); empty text is None.

    Raises:
        InputError: too long, not valid YAML, an alias bomb or a duplicate key (one line).
    """
    if len(text) > MAX_BYTES:
        raise InputError(f'{where}: {len(text)} characters of YAML (at most {MAX_BYTES})')
    try:
        return yaml.load(text, Loader=_StrictLoader)     # noqa: S506 - a safe loader
    except _Refused as exc:
        raise InputError(f'{where}: {exc}') from None
    except yaml.YAMLError as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(f'{where}: not valid YAML: {first[:200]}') from None
    except RecursionError:
        raise InputError(f'{where}: nested too deeply') from None


def load_written(text: str) -> Any:
    """Parse YAML that a recorder wrote (a bag's metadata.yaml, the run description it
    holds) with the safe loader, through libyaml where PyYAML has it (a run description is
    about 20 kB: 45 ms in the Python loader, a tenth of it in libyaml). Not for what a user
    hands pam_bench: that is ``load_yaml``'s.

    Raises:
        yaml.YAMLError: not valid YAML.
    """
    return yaml.load(text, Loader=_Base)     # noqa: S506 - a safe loader


def parse_yaml(text: str, where: str) -> dict[str, Any]:
    """Parse YAML text that must hold a mapping (empty text: an empty mapping).

    Raises:
        InputError: as ``load_yaml``, or not a mapping at the top level.
    """
    data = load_yaml(text, where)
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise InputError(f'{where}: expected a mapping at the top level')
    return data


def read_text(path: pathlib.Path, limit: int = MAX_BYTES) -> str:
    """The UTF-8 text of a file of at most ``limit`` bytes.

    Raises:
        InputError: missing, unreadable, too large or not UTF-8.
    """
    try:
        size = path.stat().st_size
        if size > limit:
            raise InputError(f'{path}: {size} bytes (a YAML file of pam_bench holds at most '
                             f'{limit})')
        with open(path, 'rb') as fh:
            data = fh.read(limit + 1)
    except OSError as exc:
        if isinstance(exc, InputError):
            raise
        raise InputError(f'{path}: cannot read: {exc.strerror or exc}') from None
    if len(data) > limit:
        raise InputError(f'{path}: more than {limit} bytes')
    try:
        return data.decode('utf-8')
    except UnicodeDecodeError as exc:
        raise InputError(f'{path}: not UTF-8 text (byte {exc.start})') from None


def read_yaml(path: pathlib.Path) -> dict[str, Any]:
    """Read a YAML file that holds a mapping (``read_text``, ``parse_yaml``).

    Raises:
        InputError: the file is missing, unreadable, too large, not UTF-8, not YAML or not a
            mapping.
    """
    return parse_yaml(read_text(path), str(path))
