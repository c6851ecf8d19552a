"""Where the repository and its files are, and what a process has loaded: for tests."""

import os
from pathlib import Path
from typing import Optional

#: The repository root (the folder holding package.xml).
REPO = Path(__file__).resolve().parents[2]
#: The package's config folder.
CONFIG = REPO / 'config'
#: Environment variable naming the shared folder (recordings, tools) explicitly.
SHARED_ENV = 'EYE_BCI_SHARED'


def shared_dir() -> Optional[Path]:
    """
    Find the ``shared`` folder beside the clone (recordings, tools), or None.

    ``$EYE_BCI_SHARED`` first; then ``shared`` beside the repository or beside
    any folder above it (a CI clone has ``../shared``; a git worktree deeper
    down finds the same folder further up).
    """
    named = os.environ.get(SHARED_ENV)
    if named:
        return Path(named) if Path(named).is_dir() else None
    for folder in REPO.parents:
        if (folder / 'shared').is_dir():
            return folder / 'shared'
    return None


def loaded(pid: int, library: str) -> bool:
    """Tell whether process ``pid`` has a file named like ``library`` mapped (False once gone)."""
    try:
        return library in Path(f'/proc/{pid}/maps').read_text()
    except FileNotFoundError:
        return False
