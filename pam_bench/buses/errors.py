"""Errors of the field buses: a bad register map or EDS, an unreachable server or bus."""

from __future__ import annotations

from pam_bench.vocabulary.errors import PamBenchError, ParameterError

__all__ = ['BusError', 'MapError', 'BusUnreachable']


class BusError(PamBenchError):
    """Base of the field-bus errors."""


class MapError(BusError, ParameterError):
    """A register map or an EDS is malformed, unknown or inconsistent (names the key)."""


class BusUnreachable(BusError, OSError):
    """A Modbus server or a CAN bus cannot be reached (names the address)."""
