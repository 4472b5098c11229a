"""The one error base of pam_bench, and the errors of the shared vocabulary.

Every error a package raises on purpose subclasses ``PamBenchError`` and the builtin it fits
(``ValueError`` for bad input, ``OSError`` for a file system or a network, ``RuntimeError`` for
a run that could not complete). The command line maps the base to one line on stderr and the
error's ``exit_code`` (``cli.errors``), so no error of the package reaches a user as a
traceback; a bug (anything else) still shows one.
"""

from __future__ import annotations

import reprlib

__all__ = ['PamBenchError', 'ParameterError', 'InputError', 'OutputError', 'shorten', 'quoted']


class PamBenchError(Exception):
    """Base of every pam_bench error: its message is one line a user can act on."""

    exit_code = 2
    """What ``pam-bench`` exits with when this error ends a verb."""


class ParameterError(PamBenchError, ValueError):
    """A setting is unknown, malformed or out of its range; the message names its path."""


class InputError(PamBenchError, ValueError):
    """An input file or argument is too large, not text, or not what it must be."""


class OutputError(PamBenchError, OSError):
    """A verb may not write where it was asked to (the message says why and what to do)."""


QUOTE_CHARS = 80
"""The longest quoted value a message holds (``shorten``)."""


def shorten(value: object, limit: int = QUOTE_CHARS) -> str:
    """``value`` as a short repr (at most ``limit`` characters, nesting and lists cut), for
    quoting in a message: a value a user typed may be megabytes long, or an alias bomb."""
    text = _REPR.repr(value)       # bounded work however large or nested the value
    if len(text) <= limit:
        return text
    return f'{text[:limit]}...'


def quoted(name: str, limit: int = QUOTE_CHARS) -> str:
    """A key or name a user wrote, quoted as ``'name'`` with control characters escaped and
    cut to ``limit`` characters (a message stays one line)."""
    text = repr(name[:limit])
    return text if len(name) <= limit else text[:-1] + '...' + text[-1]


_REPR = reprlib.Repr()
_REPR.maxlevel, _REPR.maxlist, _REPR.maxdict, _REPR.maxtuple = 3, 6, 6, 6
_REPR.maxstring, _REPR.maxother, _REPR.maxlong = QUOTE_CHARS, QUOTE_CHARS, 40
