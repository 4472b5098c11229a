"""The ``pam-bench`` command line: one module per group of verbs, one place for exit codes."""

from __future__ import annotations

from pam_bench.cli.main import command, main

__all__ = ['main', 'command', 'bags', 'bench', 'design', 'errors', 'fit', 'json_out', 'numbers',
           'plugins', 'run']
