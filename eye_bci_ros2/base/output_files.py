"""
Output files of a session that costs a person's attention: checked before, kept after.

A calibration or a validation is minutes of someone looking at targets or
flickers.  Its output path is tried before the first trial or target
(:func:`unwritable`: a missing or read-only directory refuses the session at
once), and a write that still fails at the end (a directory removed, a disk
unmounted meanwhile) goes to a file in the temp directory, named in one line
(:func:`save_or_fallback`), so the result is never lost.  ``ssvep_calibrate``
and ``gaze_validation`` both write through here.
"""

import os
import tempfile
import time
from typing import Callable, Optional


def unwritable(path: str) -> Optional[str]:
    """
    Return why ``path`` cannot be written (one line), or None when it can.

    Tried for real (opened for appending, a new file removed again), so a missing or
    read-only directory, a directory of that name or a full disk are all caught.
    """
    existed = os.path.exists(path)
    try:
        with open(path, 'ab'):
            pass
    except OSError as error:
        return f"cannot write '{path}': {error.strerror or error}"
    if not existed:
        os.remove(path)
    return None


def fallback_path(path: str, program: str) -> str:
    """Return where a file meant for ``path`` goes when ``path`` fails: the temp dir, stamped."""
    stamp = time.strftime('%Y%m%d-%H%M%S')
    return os.path.join(tempfile.gettempdir(),
                        f'{program}-{stamp}-{os.getpid()}-{os.path.basename(path)}')


def save_or_fallback(path: str, save: Callable[[str], object], what: str, program: str,
                     say: Callable[[str], None],
                     file_of: Callable[[str], str] = lambda path: path) -> str:
    """
    Write with ``save(path)``; when that fails, write to :func:`fallback_path` instead.

    :param what: what is saved ('the model'), for the line said.
    :param program: names the fallback file.
    :param say: takes the one line that names the fallback file (stderr, a logger).
    :param file_of: the file ``save(path)`` writes (``np.savez`` adds ``.npz``).
    :returns: the file written.
    :raises OSError: when the fallback cannot be written either.
    """
    try:
        save(path)
        return file_of(path)
    except OSError as error:
        fallback = file_of(fallback_path(file_of(path), program))
        save(fallback)
        say(f"cannot write '{file_of(path)}' ({error.strerror or error}): {what} saved to "
            f'{fallback} instead')
        return fallback
