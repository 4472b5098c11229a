# pam_bench: the two commands a newcomer needs are `make demo` and `make test`.
# Both set up .venv first (ROS 2 Jazzy wheels, msg_defs/ build, pam_bench) when needed.
SHELL := /bin/bash
VENV := .venv
PY := $(VENV)/bin/python
# DDS stays on loopback; every make run gets its own domain unless the caller chose one.
export ROS_AUTOMATIC_DISCOVERY_RANGE := LOCALHOST
export ROS_DOMAIN_ID ?= $(shell python3 -c 'import os; print(1 + os.getpid() % 100)')
export OPENBLAS_NUM_THREADS := 1
export OMP_NUM_THREADS := 1

.PHONY: setup demo test check lint bench calibration inverse-model servo-compare clean

setup:
	@bash tools/bootstrap.sh

demo: setup
	$(VENV)/bin/pam-bench run demo --out bags/demo --overwrite

test:
	@bash tools/bootstrap.sh --with-js
	$(PY) -m ruff check pam_bench benchmarks test
	$(PY) -m mypy
	$(PY) -m vulture pam_bench benchmarks test tools/vulture_allow.py --min-confidence 60
	$(PY) -m pytest -q -n 2 --dist worksteal -m 'not wallclock' --durations=10 test
	PAM_BENCH_TEST_DOMAIN_START=80 $(PY) -m pytest -q -p no:xdist -m wallclock --durations=10 test

# the quick tier: every test that needs neither ROS nor a clock nor a fit (under a minute)
check: setup
	$(PY) -m ruff check pam_bench benchmarks test
	$(PY) -m pytest -q -n 2 --dist worksteal -m 'not ros and not wallclock and not slow' test

lint: setup
	$(PY) -m ruff check pam_bench benchmarks test
	$(PY) -m mypy
	$(PY) -m vulture pam_bench benchmarks test tools/vulture_allow.py --min-confidence 60

# the benchmark studies -> BENCHMARKS.md and results/bench.json (hours; ARGS='--quick', '--only
# layouts,profile', '--list': python -m benchmarks --help)
bench: setup
	$(PY) -m benchmarks $(ARGS)

calibration: setup
	$(VENV)/bin/pam-bench calibration --json

# the torque servo's inverse model: identify it from a recorded run (about 5 min)
inverse-model: setup
	$(VENV)/bin/pam-bench run identification --out bags/identification --overwrite
	$(VENV)/bin/pam-bench extract bags/identification --out reports/identification --overwrite
	{ sed -n '1,5p' config/inverse_model.yaml; cat reports/identification/inverse_model.yaml; } \
		> config/inverse_model.yaml.new && mv config/inverse_model.yaml.new config/inverse_model.yaml

# every servo scene x controller through the ROS nodes, composed in one process -> reports/servo
servo-compare: setup
	$(VENV)/bin/pam-bench servo-compare --engine ros --out reports/servo --overwrite

clean:
	rm -rf bags/*/ .pytest_cache .ruff_cache
