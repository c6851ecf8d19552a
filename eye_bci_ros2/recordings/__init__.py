"""Recordings of real people (gaze, EEG) read into the core's arrays: pure loaders."""

import os
from pathlib import Path
from typing import Optional

#: Environment variable naming a folder that holds the development recordings
#: (``real_gaze/``, ``real_eeg/``), when they are not in ``../shared/data``.
DATA_ENV = 'EYE_BCI_DATA'


def shared_data(name: str) -> Optional[Path]:
    """
    Return the folder of the development recordings ``name`` (e.g. 'real_gaze'), or None.

    Looked for in ``$EYE_BCI_DATA/<name>``, then in ``shared/data/<name>``
    beside the repository or beside any folder above it (a CI clone has
    ``../shared`` next to it; a git worktree further down finds it too).
    The recordings are never part of the repository: tests skip and
    benchmarks say so when this returns None.
    """
    if os.environ.get(DATA_ENV):
        folder = Path(os.environ[DATA_ENV]) / name
        return folder if folder.is_dir() else None
    here = Path(__file__).resolve().parents[2]      # the repository, for a source checkout
    for parent in here.parents:
        folder = parent / 'shared' / 'data' / name
        if folder.is_dir():
            return folder
    return None
