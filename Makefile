# quadmission: the two commands a user needs on a fresh machine.

# The interpreter .venv is made from: on Linux the distribution's CPython when it is 3.11 or
# newer, else the first python3 on PATH. Debian builds /usr/bin/python3 with profile-guided
# optimisation and LTO, statically linked; a pyenv build (often first on PATH) has neither
# and flies our simulation ~15 % slower (benchmarks/bench_interpreter.py; bench_sitl.py
# records which interpreter ran). Another: make PYTHON=/path/to/python3 (after rm -rf .venv).
ifeq ($(origin PYTHON),undefined)
ifeq ($(shell uname -s),Linux)
PYTHON := $(shell /usr/bin/python3 -c 'import sys; sys.exit(sys.version_info < (3, 11))' \
            2>/dev/null && echo /usr/bin/python3 || echo python3)
else
PYTHON := python3
endif
endif
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp
# px4_msgs and quadmission_interfaces built as ROS 2 packages into the venv (rosidl, colcon)
ROS_STAMP := $(VENV)/share/quadmission/ros_interfaces.json
# (the msg/srv/action folders too: their mtime changes when a file is added or removed)
ROS_SOURCES := $(wildcard interfaces/px4_msgs/* interfaces/px4_msgs/*/* \
                          interfaces/quadmission_interfaces/* interfaces/quadmission_interfaces/*/*) \
               interfaces/ros_packages.py tools/build_ros_interfaces.py
OUT    ?= runs/default
# uv installs the packages: the same wheels as pip, in parallel, ~10 s from its cache where pip
# takes ~3 minutes (the ROS 2 wheels are many); pip itself only installs uv into the venv
UV_INSTALL := $(BIN)/uv pip install --quiet --python $(BIN)/python

.PHONY: setup test test-realtime sim fly-realtime lint typecheck bench docs mutate mutate-clean clean \
        system-deps ros-interfaces

## make: set up .venv (Python packages, ROS 2 Jazzy, our interface packages built with rosidl)
setup: $(ROS_STAMP)

# System libraries the Python wheels need: Mesa EGL for headless MuJoCo rendering, libusb for
# open3d's import; Debian's headless Chromium for the operator page's browser tests
# (tests/ground_station, driven by Playwright); CMake, a C/C++ compiler and Python's headers
# for building our ROS 2 interface packages (tools/build_ros_interfaces.py, which names any
# that is missing). Installed with apt-get when missing and we are root; otherwise named.
SYSTEM_LIBS := libusb-1.0.so.0 libEGL.so.1
SYSTEM_BINS := /usr/bin/chromium /usr/bin/cmake /usr/bin/gcc /usr/bin/g++
SYSTEM_PKGS := libusb-1.0-0 libegl1 libgl1-mesa-dri chromium chromium-driver cmake gcc g++ \
               python3-dev

system-deps:
	@missing=""; for lib in $(SYSTEM_LIBS); do ldconfig -p | grep -q "$$lib" || missing="$$missing $$lib"; done; \
	for bin in $(SYSTEM_BINS); do test -x "$$bin" || missing="$$missing $$bin"; done; \
	$(PYTHON) -c 'import os, sys, sysconfig; sys.exit(not os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")))' \
	  || missing="$$missing Python.h"; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    echo "installing system libraries:$$missing" >&2; \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $(SYSTEM_PKGS) >/dev/null; \
	  else \
	    echo "error: missing$$missing; run: sudo apt-get install $(SYSTEM_PKGS)" >&2; exit 1; \
	  fi; \
	fi

$(STAMP): pyproject.toml | system-deps
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else "quadmission needs Python >= 3.11")'
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV) || { \
	  if [ "$(PYTHON)" = /usr/bin/python3 ] && [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    echo "installing python3-venv (Debian's venv module)" >&2; rm -rf $(VENV); \
	    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv >/dev/null \
	      && $(PYTHON) -m venv $(VENV); \
	  else false; fi; } || { \
	  echo "error: could not create $(VENV); on Debian/Ubuntu run: apt-get install python3-venv" >&2; exit 1; }
	$(BIN)/python -m pip install --quiet --upgrade pip uv
	$(UV_INSTALL) -e '.[test,ros2]'
	@touch $@

# Builds px4_msgs and quadmission_interfaces into the venv as ROS 2 packages (rosidl, colcon)
# only when an interface file, the builder or the ROS wheels changed (its own stamp holds
# their digest; a no-op run takes under a second); the first build takes about 2 minutes on
# 2 idle cores (C and Python only: 143-152 CPU seconds).
$(ROS_STAMP): $(STAMP) $(ROS_SOURCES)
	$(BIN)/python tools/build_ros_interfaces.py
	@touch $@

## make ros-interfaces: (re)build only the interface packages (make and make test do it too)
ros-interfaces: $(ROS_STAMP)

## make test: set up .venv (with the ROS 2 interface packages), then lint, type-check and run
## the whole test suite, a pytest-xdist worker per core (each module on one worker, the
## modules of slow tests first: tests/conftest.py;
## PYTEST_WORKERS=1 for one); the ROS 2 tests run, and fail rather than skip if the build is
## missing. Then the wall-clock flights (marker realtime), alone: they keep up with the
## host's clock and need its cores (beside a parallel test worker a flight once lost its
## FCU link mid-exploration)
test: $(ROS_STAMP)
	$(BIN)/ruff check .
	$(BIN)/mypy
	MUJOCO_GL=$${MUJOCO_GL:-egl} QUADMISSION_REQUIRE_ROS2=1 $(BIN)/python -m pytest -q \
	  -n $${PYTEST_WORKERS:-auto} --dist loadscope --no-loadscope-reorder -m "not realtime"
	$(MAKE) --no-print-directory test-realtime

## make test-realtime: the wall-clock flights alone, one at a time
test-realtime: $(ROS_STAMP)
	MUJOCO_GL=$${MUJOCO_GL:-egl} QUADMISSION_REQUIRE_ROS2=1 $(BIN)/python -m pytest -q \
	  -n 0 -m realtime

## make sim: set up .venv, then fly the contest mission through every node (default arena),
## recording its topics to OUT/bag (rosbag2 MCAP)
sim: $(STAMP)
	MUJOCO_GL=$${MUJOCO_GL:-egl} $(BIN)/quadmission sim --record --out $(OUT)

## make fly-realtime: the mission in real time: `quadmission vehicle` on the wall clock,
## config/launch/companion.yaml and the simulated operator, each in processes of their own
## (ROS domain 38), scored against the vehicle's truth in runs/realtime/report.json
fly-realtime: $(ROS_STAMP)
	MUJOCO_GL=$${MUJOCO_GL:-egl} $(BIN)/quadmission fly-realtime --out runs/realtime

lint: $(STAMP)
	$(BIN)/ruff check .

typecheck: $(STAMP)
	$(BIN)/mypy

## make bench: every benchmark, each writing benchmarks/results/<name>.json
bench: $(STAMP)
	@{ $(BIN)/python -c 'import tcod, networkx' 2>/dev/null && test -x $(BIN)/py-spy; } \
	  || $(UV_INSTALL) -e '.[test,ros2,bench]'
	@for script in benchmarks/bench_*.py; do \
	  name=$$(basename $$script .py); name=$${name#bench_}; \
	  echo "== $$name"; \
	  MUJOCO_GL=$${MUJOCO_GL:-egl} $(BIN)/python $$script --out benchmarks/results/$$name.json || exit 1; \
	done

## make docs: rewrite docs/results.md and the README's headline table from
## benchmarks/results/*.json (after make bench; standard library only, no .venv needed);
## tests/tools/test_results_page.py fails when they are stale
docs:
	$(PYTHON) tools/results_page.py

## make mutate: mutation testing (mutmut) of the pure modules; prints killed/total per module
## and fails below MUTATE_MIN_KILL %. Not part of `make test` (CPU-heavy: minutes per module).
## MUTATE_PATHS: modules or folders to mutate; each one's tests mirror it under tests/
## (tests/sim/fcu/test_control*.py), or name them: path.py=tests/x.py,tests/y.py; path.py:f,g
## keeps the functions or classes f and g (C.m: the method m of class C). Tests marked slow
## are left out.
## MUTATE_ARGS=--survivors re-tests only what the last run did not kill.
MUTATE_PATHS    ?= sim/fcu/commander.py \
  sim/fcu/control.py:mix_with_desaturation,Mixer,_mixer_columns,_frd_flu \
  sim/fcu/kernels.py:mix_kernel,_desaturate,_desaturation_gain=tests/sim/fcu/test_control.py,tests/sim/fcu/test_fcu_math_recorded.py \
  interfaces/px4/timesync.py=tests/interfaces/px4/test_timesync.py,tests/interfaces/px4/test_timesync_exchange.py,tests/flight_control/test_timesync.py \
  flight_control/behaviours/ \
  flight_control/command_protocol.py \
  navigation/precision_land_policy.py \
  perception/scan_policy.py \
  flight_control/pose_history.py \
  flight_control/bridge_node.py:FcuBridgeNode.to_companion_ns,FcuBridgeNode.to_fcu_us,FcuBridgeNode._stamp=tests/flight_control/test_bridge_node_clocks.py \
  navigation/precision_landing.py \
  navigation/navigator_policy.py \
  fsm/mission_driver.py \
  navigation/astar.py
MUTATE_CHILDREN ?= 1
MUTATE_MIN_KILL ?= 90
MUTATE_ARGS     ?=

mutate: $(STAMP)
	@$(BIN)/python -c 'import mutmut' 2>/dev/null || $(UV_INSTALL) -e '.[test,ros2,mutate]'
	MUJOCO_GL=$${MUJOCO_GL:-egl} NUMBA_DISABLE_JIT=1 $(BIN)/python tools/mutate.py \
	  --max-children $(MUTATE_CHILDREN) --min-kill-percent $(MUTATE_MIN_KILL) $(MUTATE_ARGS) \
	  $(MUTATE_PATHS)

## make mutate-clean: forget mutmut's results (./mutants)
mutate-clean:
	rm -rf mutants

clean:
	rm -rf $(VENV) build *.egg-info .pytest_cache .mypy_cache .ruff_cache mutants
