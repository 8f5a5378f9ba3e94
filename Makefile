# Two commands do all the set-up: `make demo` and `make test`. Each builds .venv from PyPI first.
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed

# DDS discovery stays on this machine, on a domain of its own (the test suite: 1..70; its fixed end-to-end ids: 71..92).
export ROS_AUTOMATIC_DISCOVERY_RANGE := LOCALHOST
export ROS_DOMAIN_ID ?= $(shell $(PYTHON) -c 'import os; print(1 + os.getpid() % 70)')
export PYTHONDONTWRITEBYTECODE := 1

SCENARIO ?= polar_two_link
QUICK    ?= 0

.PHONY: venv test demo bench check-ros2 clean

venv: $(STAMP)

$(STAMP): requirements.txt setup.py
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --disable-pip-version-check --upgrade pip wheel
	$(PY) -m pip install --quiet --disable-pip-version-check -r requirements.txt
	$(PY) -m pip install --quiet --disable-pip-version-check --no-deps --no-build-isolation -e .
	touch $(STAMP)

test: $(STAMP)
	$(PY) -m pytest -q test

demo: $(STAMP)
	$(PY) -m robot_control.demo --scenario $(SCENARIO)

bench: $(STAMP)
	$(PY) -m benchmarks.bench $(if $(filter 1,$(QUICK)),--quick,)

# Needs a `ros2` command on PATH (a sourced Jazzy install or the stand-in, see README); not part of `make test`.
check-ros2: $(STAMP)
	$(PY) -m dev.check_ros2

clean:
	rm -rf $(VENV) out build install log *.egg-info
