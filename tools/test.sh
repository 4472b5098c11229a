#!/usr/bin/env bash
# The test suite as `make test` runs it, in two sessions at once on disjoint DDS domains:
# - the wall-clock tests (marker `wallclock`: deadlines, rates, kill-to-vent latencies), one at
#   a time at ordinary priority, their output on the terminal;
# - the lock-step and offline tests on two pytest-xdist workers at the lowest priority (nice
#   19): they take the CPU the wall-clock runs leave, and the scheduler hands it back to those
#   at once when they wake (a nice-19 task weighs 15 against 1024). Their output follows.
# The exit status is non-zero when either session fails.
set -uo pipefail
cd "$(dirname "$0")/.."
PY=.venv/bin/python
log=$(mktemp -t pam_bench_lockstep_tests.XXXXXX)
trap 'rm -f "$log"' EXIT
# its own process group (setsid), so that Ctrl-C reaches it through the trap below; a
# background job starts with SIGINT ignored, and test/conftest.py turns it back on
PAM_BENCH_TEST_DOMAIN_END=80 setsid nice -n 19 "$PY" -m pytest -q -n 2 -m 'not wallclock' \
    test "$@" >"$log" 2>&1 &
lock=$!
trap 'kill -INT -- -"$lock" 2>/dev/null; wait "$lock"; rm -f "$log"; exit 130' INT TERM
echo "lock-step and offline tests running in the background (nice 19); wall-clock tests:"
PAM_BENCH_TEST_DOMAIN_START=80 "$PY" -m pytest -q -p no:xdist -m wallclock test "$@"
wall=$?
wait "$lock"
lockrc=$?
echo "--- lock-step and offline tests ---"
cat "$log"
if [ "$wall" -ne 0 ] || [ "$lockrc" -ne 0 ]; then
    echo "make test: failed (wall-clock tests exit $wall, lock-step tests exit $lockrc)" >&2
    exit 1
fi
