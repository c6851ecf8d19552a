"""
Recordings of real people (gaze, EEG) read into the core's arrays: pure loaders.

Third-party recordings are never part of the repository: benchmarks take a
folder (``--data DIR``), and tests and benchmarks look for the development
copies with :func:`find_data`.
"""

import os
from pathlib import Path
from typing import Optional

#: Environment variable naming a folder that holds ``real_gaze/``, ``real_eeg/``, ...
DATA_ENV = 'EYE_BCI_DATA'


def find_data(kind: str) -> Optional[Path]:
    """
    Find the folder of real recordings of one kind ('real_gaze', 'real_eeg').

    ``$EYE_BCI_DATA/<kind>`` when that variable is set, else
    ``shared/data/<kind>`` beside the source tree or beside any folder above it
    (a clone at ``X/main`` finds ``X/shared/data``).

    :returns: the folder, or None when there is none.
    """
    if os.environ.get(DATA_ENV):
        folder = Path(os.environ[DATA_ENV]) / kind
        return folder if folder.is_dir() else None
    for parent in Path(__file__).resolve().parents[2:]:
        folder = parent / 'shared' / 'data' / kind
        if folder.is_dir():
            return folder
    return None
