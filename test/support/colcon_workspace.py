"""
A colcon workspace with a copy of the package, built as a ROS 2 user builds it.

Used by the system tests that need what ``colcon build`` installs (``ros2
run``, ``ros2 launch``, the ament index).  The real ``ros2`` command line
(ros2cli, launch, launch_ros) is not on PyPI: :func:`ros2_command` installs it
from ``../shared/tools/ros2cli/install.sh`` into ``build/`` when that script
is there; without the script, or where it cannot download, it raises
:class:`Unavailable` (the tests then skip with the reason).
"""

import fcntl
import os
from pathlib import Path
import re
import shutil
import subprocess
import sys
from typing import Dict

from paths import REPO, shared_dir

PACKAGE = 'eye_bci_ros2'
#: What an ament_python package needs to build; the rest (tests, bench, docs) is not installed.
PACKAGE_FILES = ['setup.py', 'setup.cfg', 'package.xml', 'resource', 'config', 'launch',
                 PACKAGE]
BUILD_TIMEOUT_S = 600
#: Where the ros2 command line is installed (build/ is the colcon build folder, ignored by git).
ROS2CLI_DIR = REPO / 'build' / 'ros2cli'


def build_workspace(workspace: Path) -> Path:
    """Copy the package into ``workspace/src`` and build it with the venv's colcon."""
    source = workspace / 'src' / PACKAGE
    source.mkdir(parents=True)
    ignore = shutil.ignore_patterns('__pycache__', '*.pyc', '*.egg-info')
    for name in PACKAGE_FILES:
        if (REPO / name).is_dir():
            shutil.copytree(REPO / name, source / name, ignore=ignore)
        else:
            shutil.copy2(REPO / name, source / name)
    colcon = Path(sys.prefix) / 'bin' / 'colcon'
    assert colcon.is_file(), f'colcon is not installed in the venv {sys.prefix}'
    # Keep colcon's log and user defaults out of the repository and home directory.
    env = dict(os.environ, COLCON_HOME=str(workspace / 'colcon_home'),
               PYTHONDONTWRITEBYTECODE='1')
    build = subprocess.run(
        [str(colcon), '--log-base', str(workspace / 'log'), 'build',
         '--base-paths', 'src', '--build-base', 'build', '--install-base', 'install',
         '--event-handlers', 'console_direct+'],
        cwd=workspace, env=env, capture_output=True, text=True, timeout=BUILD_TIMEOUT_S)
    assert build.returncode == 0, \
        f'colcon build failed ({build.returncode}):\n{build.stdout}\n{build.stderr}'
    return workspace


def clean_environment() -> Dict[str, str]:
    """Return this process's environment without a sourced ROS workspace."""
    return {key: value for key, value in os.environ.items()
            if key not in ('AMENT_PREFIX_PATH', 'PYTHONPATH', 'COLCON_PREFIX_PATH')}


def sourced(workspace: Path, command: list, **kwargs) -> subprocess.CompletedProcess:
    """Run ``command`` after `. install/setup.sh`, as a user of the workspace would."""
    return subprocess.run(
        ['sh', '-c', '. "$0/install/setup.sh" && exec "$@"', str(workspace), *command],
        cwd=workspace, env=clean_environment(), capture_output=True, text=True, **kwargs)


def sourced_environment(workspace: Path) -> Dict[str, str]:
    """Return the environment after `. install/setup.sh` (for Popen)."""
    result = subprocess.run(
        ['sh', '-c', '. "$0/install/setup.sh" && env -0', str(workspace)],
        env=clean_environment(), capture_output=True, text=True, check=True, timeout=60)
    pairs = (entry.split('=', 1) for entry in result.stdout.split('\0') if '=' in entry)
    return dict(pairs)


#: What pip says when it cannot download (no network, or no index holding the package): the
#: installer's download step failed, which is the machine's, not this package's.
NO_DOWNLOAD = re.compile(r'No matching distribution found|Could not find a version|'
                         r'Failed to establish a new connection|Network is unreachable|'
                         r'Temporary failure in name resolution|Name or service not known|'
                         r'ProxyError|Read timed out|Connection refused', re.IGNORECASE)


class Unavailable(Exception):
    """The real ros2 command line cannot be had here; the message says why (for a skip)."""


def ros2_command() -> Path:
    """
    Install the real ros2 command line if its installer is at hand; return ``ros2``.

    :raises Unavailable: no installer beside the clone, or it could not download
        what it installs (its last error line says what).  Any other failure of the
        installer fails the test that asked.
    """
    shared = shared_dir()
    installer = shared / 'tools' / 'ros2cli' / 'install.sh' if shared else None
    if installer is None or not installer.is_file():
        raise Unavailable('no ../shared/tools/ros2cli/install.sh beside the clone '
                          '(or $EYE_BCI_SHARED)')
    # Two test files may ask at once (pytest-xdist workers): one installs, the other waits.
    ROS2CLI_DIR.parent.mkdir(parents=True, exist_ok=True)
    with open(ROS2CLI_DIR.parent / 'ros2cli.lock', 'w') as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        result = subprocess.run(['bash', str(installer), sys.executable, str(ROS2CLI_DIR)],
                                capture_output=True, text=True, timeout=BUILD_TIMEOUT_S)
    if result.returncode == 0:
        return Path(result.stdout.strip().splitlines()[-1])
    # The installer sends pip's output to install.log in the folder it fills.
    log = ROS2CLI_DIR / 'install.log'
    text = '\n'.join([result.stdout, result.stderr,
                      log.read_text(errors='replace') if log.is_file() else ''])
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    errors = [line for line in lines if line.startswith('ERROR')] or lines
    if NO_DOWNLOAD.search(text):
        raise Unavailable(f'{installer} could not download: '
                          f'{errors[-1] if errors else "no message"}')
    raise AssertionError(f'{installer} failed ({result.returncode}):\n' + '\n'.join(lines[-30:]))
