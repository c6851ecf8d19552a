"""The pure core imports no rclpy, pylsl, matplotlib or pyglet (docs/DESIGN.md, "Layers")."""

import json
import os
import pkgutil
import subprocess
import sys

from paths import REPO

import eye_bci_ros2

#: Packages of the package that may use ROS, LSL, plots or a window.
IMPURE_PACKAGES = ('ros', 'nodes', 'sim', 'experiments', 'tools')
#: What the pure core must not load.
FORBIDDEN = ('rclpy', 'pylsl', 'matplotlib', 'pyglet', 'ament_index_python')


def pure_modules():
    """Every module of eye_bci_ros2 outside the adapter, simulation, experiment and tool parts."""
    names = []
    for info in pkgutil.walk_packages(eye_bci_ros2.__path__, 'eye_bci_ros2.'):
        if info.name.split('.')[1] not in IMPURE_PACKAGES:
            names.append(info.name)
    return sorted(names)


def test_the_pure_core_is_found():
    names = pure_modules()
    for expected in ('eye_bci_ros2.projection.geometry', 'eye_bci_ros2.decision.rounds',
                     'eye_bci_ros2.gaze.stream',
                     'eye_bci_ros2.projection.camera_model', 'eye_bci_ros2.task.scene',
                     'eye_bci_ros2.navigation.planner', 'eye_bci_ros2.navigation.drive'):
        assert expected in names
    assert not [name for name in names if '.nodes' in name or '.sim' in name]


def test_pure_modules_load_no_ros_lsl_or_plotting_in_a_fresh_interpreter():
    code = ('import importlib, json, sys\n'
            f'for name in {pure_modules()!r}:\n'
            '    importlib.import_module(name)\n'
            f'print(json.dumps(sorted(m for m in {FORBIDDEN!r} if m in sys.modules)))\n')
    done = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                          cwd=REPO, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.strip() == '[]', f'the pure core loaded {done.stdout.strip()}'


#: What importing the package must leave as it was, read in the importing process.
PROCESS_STATE = (
    'import json, os, signal, sys\n'
    'def state():\n'
    '    return {"excepthook": sys.excepthook is sys.__excepthook__,\n'
    '            "sigint": signal.getsignal(signal.SIGINT) is signal.default_int_handler,\n'
    '            "environ": dict(os.environ)}\n')


def test_importing_the_package_leaves_the_process_alone(tmp_path):
    """
    A library user (a notebook importing the projection) keeps their process as it was.

    No excepthook, no SIGINT handler, no environment variable (liblsl's
    ``LSLAPICFG``) and no file written: that is the executables' start-up
    (``eye_bci_ros2.ros.startup``), not the package's import.
    """
    temporary, home = tmp_path / 'tmp', tmp_path / 'home'
    temporary.mkdir()
    home.mkdir()
    modules = pure_modules() + ['eye_bci_ros2.ros.registry', 'eye_bci_ros2.ros.startup']
    code = (PROCESS_STATE + 'before = state()\n'
            'import importlib\n'
            f'for name in {modules!r}:\n'
            '    importlib.import_module(name)\n'
            'print(json.dumps([before, state()]))\n')
    env = {key: value for key, value in os.environ.items() if key != 'LSLAPICFG'}
    env.update(TMPDIR=str(temporary), HOME=str(home))
    done = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                          cwd=tmp_path, env=env, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    before, after = json.loads(done.stdout)
    assert before['excepthook'] and before['sigint']     # Python's own, before the import
    assert after['excepthook'], 'importing the package replaced sys.excepthook'
    assert after['sigint'], 'importing the package replaced the SIGINT handler'
    assert after['environ'] == before['environ'], 'importing the package changed os.environ'
    assert list(temporary.iterdir()) == [], 'importing the package wrote a file'
