"""Code style: ament_flake8 over the whole repository."""

import configparser
from pathlib import Path

import ament_flake8.main
from ament_flake8.main import main_with_errors
from paths import REPO
import pytest


#: Not our code (the venv) or colcon's output; ament_flake8 itself already skips
#: every directory whose name starts with '.' or '_'.
EXCLUDED_DIRS = ['.venv', 'build', 'install', 'log']


def ament_config_with_application_names(directory: Path) -> Path:
    """
    Write ament_flake8's own configuration plus application-import-names.

    flake8 reads only the file given by ``--config``, so the project's import
    grouping (this repository's eye_bci_ros2 and bench after third-party
    packages, google style) goes into a copy of ament's file, not setup.cfg.
    """
    ament_ini = Path(ament_flake8.main.__file__).parent / 'configuration' / 'ament_flake8.ini'
    config = configparser.ConfigParser()
    config.read(ament_ini)
    config['flake8']['application-import-names'] = 'eye_bci_ros2,bench'
    path = directory / 'flake8.ini'
    with open(path, 'w') as stream:
        config.write(stream)
    return path


@pytest.mark.flake8
@pytest.mark.linter
def test_flake8(tmp_path, monkeypatch, capsys):
    # ament_flake8 walks the current directory to find what to skip.
    monkeypatch.chdir(REPO)
    config = ament_config_with_application_names(tmp_path)
    rc, errors = main_with_errors(argv=[
        '--config', str(config), str(REPO),
        '--exclude', *[str(REPO / name) for name in EXCLUDED_DIRS]])
    output = capsys.readouterr().out
    checked = [Path(line[2:]) for line in output.splitlines() if line.startswith('* ')]
    # Guard against silently checking nothing, or checking the venv.
    assert REPO / 'eye_bci_ros2' / 'projection' / 'geometry.py' in checked
    assert REPO / 'test' / 'lint' / 'test_flake8.py' in checked
    assert not [path for path in checked
                if set(path.relative_to(REPO).parts) & set(EXCLUDED_DIRS)]
    assert rc == 0, \
        'Found %d code style errors / warnings:\n' % len(errors) + '\n'.join(errors)
