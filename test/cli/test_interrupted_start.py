"""Ctrl-C while ``pam-bench`` is still starting (``cli.main``): exit 130 and one line, never a
traceback."""

from __future__ import annotations

import importlib
import signal
import subprocess
import sys
import types
from typing import Any

import pytest

from test.cli.helpers import cli

cli_main = importlib.import_module('pam_bench.cli.main')


def test_the_entry_point_imports_nothing_heavy_before_its_handlers() -> None:
    """What ``pam-bench`` imports before ``main`` puts its signal handlers in place: not the
    verb groups, not numpy (a Ctrl-C in that tenth of a second printed a traceback)."""
    code = ('import sys, pam_bench.cli.main; '
            'print(sorted(m for m in ("numpy", "rclpy", "pam_bench.cli.run", '
            '"pam_bench.cli.fit") if m in sys.modules))')
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                         timeout=60, check=True)
    assert out.stdout.strip() == '[]', out.stdout


def _verbs_cut_by(monkeypatch: pytest.MonkeyPatch, exc: BaseException,
                  signalled: bool) -> None:
    """The parser's verb groups replaced by one whose loading raises ``exc`` (after a SIGINT
    came, with ``signalled``)."""
    def register(sub: Any) -> None:
        if signalled:
            cli_main._received.append(signal.SIGINT)
        raise exc
    monkeypatch.setitem(sys.modules, 'pam_bench.cli.cut', types.SimpleNamespace(
        register=register))
    monkeypatch.setattr(cli_main, 'GROUP_MODULES', ('cut',))


@pytest.mark.parametrize('exc', [KeyboardInterrupt(), ImportError('PyCapsule_Import could '
                                                                   'not import module')])
def test_an_interrupt_while_the_verbs_import_is_one_line(
        monkeypatch: pytest.MonkeyPatch, exc: BaseException) -> None:
    """A SIGINT while the parser imports the verb groups: exit 130, 'interrupted'; what the
    signal broke on its way (numpy's import turns it into an ImportError) is the stop too."""
    _verbs_cut_by(monkeypatch, exc, True)
    code, _, err = cli('run', 'demo')
    assert (code, err.strip()) == (130, 'interrupted'), err


def test_an_import_error_without_a_signal_is_not_taken_for_one(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The control: the same ImportError with no stop signal is a fault, and shows as one."""
    _verbs_cut_by(monkeypatch, ImportError('broken install'), False)
    with pytest.raises(ImportError, match='broken install'):
        cli('run', 'demo')
