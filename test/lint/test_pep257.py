"""Docstring style: ament_pep257 over the whole repository."""

from pathlib import Path

from ament_pep257.main import main
from paths import REPO
import pytest


#: colcon's output; pydocstyle itself skips directories starting with '.' or '_'
#: (so the venv).
EXCLUDED_DIRS = ['build', 'install', 'log']

#: The brief asks for a docstring on every public module, class and function;
#: ament's convention ignores these (D100-D107), so they are added back for the package.
MISSING_DOCSTRING_CODES = ['D100', 'D101', 'D102', 'D103', 'D104', 'D106']


def excludes():
    """Return the ``--exclude`` arguments for ament_pep257."""
    return ['--exclude', *[str(REPO / name) for name in EXCLUDED_DIRS]]


@pytest.mark.linter
@pytest.mark.pep257
def test_pep257(monkeypatch, capsys):
    monkeypatch.chdir(REPO)
    rc = main(argv=[str(REPO), *excludes()])
    output = capsys.readouterr()
    checked = [Path(line.split(' ', 1)[1]) for line in output.out.splitlines()
               if line.startswith('checking ')]
    # Guard against silently checking nothing, or checking the venv.
    assert REPO / 'eye_bci_ros2' / 'projection' / 'geometry.py' in checked
    assert REPO / 'test' / 'lint' / 'test_pep257.py' in checked
    assert not [path for path in checked
                if set(path.relative_to(REPO).parts) & {'.venv', *EXCLUDED_DIRS}]
    assert rc == 0, 'Found code style errors / warnings:\n' + output.out + output.err


@pytest.mark.linter
@pytest.mark.pep257
def test_public_api_has_docstrings(monkeypatch, capsys):
    monkeypatch.chdir(REPO)
    rc = main(argv=[str(REPO / 'eye_bci_ros2'), '--add-select', *MISSING_DOCSTRING_CODES])
    output = capsys.readouterr()
    assert rc == 0, 'Public code without a docstring:\n' + output.out + output.err
