"""``python -m pam_bench.cli``: the ``pam-bench`` command."""

from __future__ import annotations

from pam_bench.cli.main import command

__all__: list[str] = []

command()
