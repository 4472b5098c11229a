#!/usr/bin/env bash
# `make test`'s two tiers at once (docs/long_runs.md, "`make test`'s floor"): the wall-clock
# tests one at a time at the ordinary priority, in the background, and the rest (lock-step and
# offline, bound by CPU) on two workers at nice 10 beside them, so the wall-clock tests keep
# their cores while the others fill what is left. Each tier takes its DDS domains from a slice
# of its own (test/conftest.py). Ctrl-C stops both; the exit status is 1 when either failed.
# Usage: tools/test_tiers.sh PYTHON
set -uo pipefail
py=${1:-.venv/bin/python}
log=$(mktemp "${TMPDIR:-/tmp}/pam_bench_wallclock.XXXXXX")
trap 'rm -f "$log"' EXIT
PAM_BENCH_TEST_DOMAIN_START=70 "$py" -m pytest -q -p no:xdist -m wallclock --durations=10 test \
    > "$log" 2>&1 &
wall=$!
nice -n 10 "$py" -m pytest -q -n 2 --dist worksteal -m 'not wallclock' --durations=10 test
rest=$?
wait "$wall"
wall_rc=$?
echo '--- the wall-clock tier (ran beside the rest)'
cat "$log"
[ "$rest" -eq 0 ] && [ "$wall_rc" -eq 0 ]
