"""The lock-step floor with no work: N separate processes acknowledge every tick."""

from __future__ import annotations

import pytest

from pam_bench.bringup.pingpong import fanout_rate


@pytest.mark.parametrize('participants', [1, 3])
def test_fanout_completes_and_gives_a_rate(ros_domain: int, participants: int) -> None:
    """Every tick is acknowledged by all participants (the count is reached, else it raises);
    the rate is finite and positive."""
    rate = fanout_rate(participants, count=200, warmup=20)
    assert 0.0 < rate < 1e6


def test_a_helper_that_ignores_sigterm_is_killed() -> None:
    """Stopping the helpers ends one that ignores SIGTERM (kill after the timeout) and one
    already gone, without raising."""
    import subprocess
    import sys

    from pam_bench.bringup.pingpong import _stop

    stubborn = subprocess.Popen([sys.executable, '-c', 'import signal, sys, time; '
                                 'signal.signal(signal.SIGTERM, signal.SIG_IGN); '
                                 'print("up", flush=True); time.sleep(60)'],
                                stdout=subprocess.PIPE, text=True)
    gone = subprocess.Popen([sys.executable, '-c', 'pass'])
    try:
        assert stubborn.stdout is not None and stubborn.stdout.readline() == 'up\n'
        gone.wait()
        _stop([stubborn, gone], timeout_s=0.5)
        assert stubborn.returncode == -9 and gone.returncode == 0
    finally:
        if stubborn.poll() is None:
            stubborn.kill()
            stubborn.wait()
