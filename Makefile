# Set-up is part of every target: a bare clone needs only python3 (3.11 or 3.12) with venv.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
# nav2_msgs, tf2_msgs and the RViz view controller's messages are not on PyPI: built with colcon
# into the venv (interfaces/README.md).
INTERFACES := $(wildcard interfaces/build.sh interfaces/cmake/*.cmake interfaces/*/package.xml \
	interfaces/*/CMakeLists.txt interfaces/*/msg/*.msg interfaces/*/action/*.action)
# Each test picks its own ROS domain; keep discovery on this machine.
export ROS_AUTOMATIC_DISCOVERY_RANGE ?= LOCALHOST
export PYTHONDONTWRITEBYTECODE := 1
# numpy's BLAS threads fight the nodes and each other on small machines (see bench/).
export OPENBLAS_NUM_THREADS ?= 1

.PHONY: demo test bench soak accuracy lint build clean

$(STAMP): requirements.txt constraints.txt setup.py setup.cfg package.xml $(INTERFACES) \
		eye_bci_ros2/ros/registry.py
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r requirements.txt -c constraints.txt
	interfaces/build.sh $(VENV)
	$(PY) -m pip install --quiet --no-deps --no-build-isolation -e .
	touch $(STAMP)

# The console scripts, as a user runs them: their start-up keeps a Ctrl-C quiet (ros/startup.py).
demo: $(STAMP)
	$(VENV)/bin/demo $(ARGS)

# Two workers (pytest-xdist), one test file each: most tests wait on ROS 2 graphs and LSL.
test: $(STAMP)
	$(PY) -m pytest test -n 2 --dist loadfile $(ARGS)

# About 10 minutes on 2 cores, each section printed as it finishes; the complete tables:
# make bench ARGS=--full (see docs/performance.md for the time of each section).
bench: $(STAMP)
	$(PY) -m bench.run_all $(ARGS)

# 10 minutes of 1200 Hz per-sample gaze with rounds back to back; a check: ARGS='--minutes 1'.
soak: $(STAMP)
	$(PY) -m bench.soak $(ARGS)

accuracy: $(STAMP)
	$(VENV)/bin/accuracy_test $(ARGS)

lint: $(STAMP)
	$(PY) -m pytest test/lint

# colcon build into ./install, as on a ROS machine (uses the venv's colcon and rclpy).
build: $(STAMP)
	$(VENV)/bin/colcon build --paths . --build-base build --install-base install

clean:
	rm -rf $(VENV) build install log demo_output bench_results.json .pytest_cache
