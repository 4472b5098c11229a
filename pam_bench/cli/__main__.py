"""``python -m pam_bench.cli``: the ``pam-bench`` command."""

from __future__ import annotations

import sys

from pam_bench.cli.main import main

__all__: list[str] = []

sys.exit(main())
