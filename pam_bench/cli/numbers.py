"""Bounded arguments: every count and duration a verb takes is finite, in a stated range, and
every path it writes names something, or one line says what it must be."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable

__all__ = ['number', 'integer', 'out_path']


def _check(value: float, text: str, low: float, high: float, low_open: bool, unit: str) -> None:
    below = value <= low if low_open else value < low
    if not math.isfinite(value) or below or value > high:
        lo = '(' if low_open else '['
        raise argparse.ArgumentTypeError(f'{text!r} is not in {lo}{low:g}, {high:g}]'
                                         + (f' {unit}' if unit else ''))


def number(low: float, high: float, unit: str = '', low_open: bool = False
           ) -> Callable[[str], float]:
    """An argparse type: a finite float in [low, high] (``low_open``: (low, high])."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f'{text[:40]!r} is not a number') from None
        _check(value, text, low, high, low_open, unit)
        return value
    parse.__name__ = 'number'
    return parse


def integer(low: int, high: int) -> Callable[[str], int]:
    """An argparse type: an integer in [low, high]."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f'{text[:40]!r} is not an integer') from None
        _check(value, text, low, high, False, '')
        return value
    parse.__name__ = 'integer'
    return parse


def out_path(text: str) -> str:
    """An argparse type for a path a verb writes: not empty (``--out ''`` would name the
    current folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError('an empty path: name a folder or file')
    return text
