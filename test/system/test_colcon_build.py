"""
The package builds with colcon and installs what `ros2 run` needs.

A copy of the package is built in a temporary workspace with the venv's
colcon; every console script of setup.py must then be found the way
`ros2 run eye_bci_ros2 <exe>` finds it (ament index -> package prefix ->
lib/eye_bci_ros2/<exe>, an executable file) in the environment of
`source install/setup.sh`, and one of them must start.
"""

import json
from pathlib import Path
import runpy
import sys

from colcon_workspace import build_workspace, PACKAGE, sourced
from paths import REPO
import pytest

#: The executable the test starts; `--help` must work without a ROS graph.
STARTED_EXECUTABLE = 'calibrate'

RUN_TIMEOUT_S = 120

# Runs in the sourced workspace: what `ros2 run` resolves (ros2run.api.get_executable_paths).
FIND_EXECUTABLES = """
import json, os, sys
from ament_index_python.packages import get_package_prefix, get_package_share_directory
import eye_bci_ros2
package = sys.argv[1]
prefix = get_package_prefix(package)
lib = os.path.join(prefix, 'lib', package)
executables = sorted(
    name for name in os.listdir(lib)
    if os.path.isfile(os.path.join(lib, name)) and os.access(os.path.join(lib, name), os.X_OK))
print(json.dumps({'prefix': prefix, 'lib': lib, 'executables': executables,
                  'share': get_package_share_directory(package),
                  'module': eye_bci_ros2.__file__}))
"""

# Runs in the sourced workspace: each console script's target imports and is callable, and
# so does the ``main`` of the module it starts (the start-up imports it only when run).
RESOLVE_ENTRY_POINTS = """
import importlib, json, sys
failures = {}
for entry in json.loads(sys.argv[1]):
    name, target = (part.strip() for part in entry.split('=', 1))
    module, _, attribute = target.partition(':')
    try:
        start = getattr(importlib.import_module(module), attribute)
        if not callable(start):
            failures[name] = target + ' is not callable'
        runs = getattr(start, 'executable_module', None)
        if runs and not callable(getattr(importlib.import_module(runs), 'main', None)):
            failures[name] = runs + ' has no main()'
    except Exception as error:
        failures[name] = '%s: %s: %s' % (target, type(error).__name__, error)
print(json.dumps(failures))
"""


def console_scripts() -> list:
    """Return the ``console_scripts`` setup.py installs: the node registry's (it reads them)."""
    registry = runpy.run_path(str(REPO / PACKAGE / 'ros' / 'registry.py'))
    return list(registry['console_scripts']())


@pytest.fixture(scope='module')
def workspace(tmp_path_factory):
    """Build a copy of the package with the venv's colcon; yield the workspace."""
    yield build_workspace(tmp_path_factory.mktemp('ws'))


@pytest.fixture(scope='module')
def installed(workspace):
    """Where the sourced workspace finds the package, as `ros2 run` would."""
    found = sourced(workspace, [sys.executable, '-c', FIND_EXECUTABLES, PACKAGE],
                    timeout=RUN_TIMEOUT_S)
    assert found.returncode == 0, found.stdout + found.stderr
    return json.loads(found.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_every_console_script_is_an_installed_executable(workspace, installed):
    prefix = workspace / 'install' / PACKAGE
    assert Path(installed['prefix']) == prefix
    # The installed copy is used, not the source tree the venv has in editable mode.
    assert Path(installed['module']).is_relative_to(prefix)
    scripts = console_scripts()
    assert scripts, 'setup.py lists no console scripts'
    expected = sorted(entry.split('=', 1)[0].strip() for entry in scripts)
    assert installed['executables'] == expected


@pytest.mark.slow
def test_config_files_are_installed(workspace, installed):
    sources = sorted((REPO / 'config').glob('*.yaml')) + sorted((REPO / 'config').glob('*.rviz'))
    assert REPO / 'config' / 'eye_bci.yaml' in sources
    assert REPO / 'config' / 'eye_bci.rviz' in sources
    config = Path(installed['share']) / 'config'
    for source in sources:
        assert (config / source.name).read_bytes() == source.read_bytes(), source.name
    launch_files = sorted((REPO / 'launch').glob('*.launch.py'))
    assert REPO / 'launch' / 'pipeline.launch.py' in launch_files
    for source in launch_files:   # `ros2 launch eye_bci_ros2 <file>` looks in share/<pkg>/launch
        installed_file = Path(installed['share']) / 'launch' / source.name
        assert installed_file.read_bytes() == source.read_bytes(), source.name
    assert (Path(installed['share']) / 'package.xml').is_file()


@pytest.mark.slow
def test_installed_executable_starts(workspace, installed):
    assert STARTED_EXECUTABLE in installed['executables']
    executable = Path(installed['lib']) / STARTED_EXECUTABLE
    result = sourced(workspace, [str(executable), '--help'], timeout=RUN_TIMEOUT_S)
    assert result.returncode == 0, result.stdout + result.stderr
    assert f'usage: {STARTED_EXECUTABLE}' in result.stdout


@pytest.mark.slow
def test_every_console_script_target_imports(workspace, installed):
    # `ros2 run` would find the file but die on start if its module is missing.
    scripts = console_scripts()
    result = sourced(workspace, [sys.executable, '-c', RESOLVE_ENTRY_POINTS,
                                 json.dumps(scripts)], timeout=RUN_TIMEOUT_S)
    assert result.returncode == 0, result.stdout + result.stderr
    failures = json.loads(result.stdout.strip().splitlines()[-1])
    assert not failures, 'console scripts that cannot start:\n' + '\n'.join(
        f'{name}: {reason}' for name, reason in sorted(failures.items()))


@pytest.mark.slow
def test_the_build_writes_a_setup_bash(workspace):
    # A ROS 2 user sources install/setup.bash (colcon-bash); setup.sh is for other shells.
    for name in ('setup.bash', 'setup.sh'):
        assert (workspace / 'install' / name).is_file(), name
