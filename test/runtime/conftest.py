"""Fixtures of the runtime tests: an rclpy context of their own on a fresh domain."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import rclpy


@pytest.fixture
def context(ros_domain: int) -> Iterator[rclpy.Context]:
    """An initialised rclpy context, shut down after the test."""
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    try:
        yield ctx
    finally:
        rclpy.try_shutdown(context=ctx)
