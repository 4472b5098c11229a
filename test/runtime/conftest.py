"""Fixtures of the runtime tests: an rclpy context of their own on a fresh domain, and the
nodes a test makes in it, destroyed after the test whatever happened."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any, TypeVar

import pytest
import rclpy

N = TypeVar('N')


@pytest.fixture
def context(ros_domain: int) -> Iterator[rclpy.Context]:
    """An initialised rclpy context, shut down after the test."""
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    try:
        yield ctx
    finally:
        rclpy.try_shutdown(context=ctx)


@pytest.fixture
def own() -> Iterator[Callable[[N], N]]:
    """``own(node)`` returns the node and destroys it after the test (the last made first);
    anything with ``destroy_node`` or ``close`` will do."""
    made: list[Any] = []

    def keep(thing: N) -> N:
        made.append(thing)
        return thing
    yield keep
    for thing in reversed(made):
        (getattr(thing, 'close', None) or thing.destroy_node)()


@pytest.fixture
def context_with(ros_domain: int) -> Iterator[Callable[[list[str]], rclpy.Context]]:
    """``context_with(args)``: an rclpy context initialised with these command-line arguments
    (a params file), shut down after the test."""
    made: list[rclpy.Context] = []

    def make(args: list[str]) -> rclpy.Context:
        ctx = rclpy.Context()
        rclpy.init(args=args, context=ctx)
        made.append(ctx)
        return ctx
    yield make
    for ctx in made:
        rclpy.try_shutdown(context=ctx)
