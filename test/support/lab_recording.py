"""A lab's own gaze recording as CSV files (eye_bci_ros2.recordings.gaze reads them)."""

from pathlib import Path

import numpy as np


def write_lab_csv(folder: Path, stamps: np.ndarray, points: np.ndarray, places: np.ndarray,
                  step_s: float, name: str = 'lab') -> None:
    """
    Write ``NAME.gaze.csv`` and ``NAME.targets.csv`` into ``folder``.

    :param stamps: (N,) s; :param points: (N, 2) gaze, screen px.
    :param places: (K, 2) px: target k appears at ``k * step_s``.
    """
    rows = '\n'.join(f'{t:.4f},{x:.1f},{y:.1f}' for t, (x, y) in zip(stamps, points))
    (folder / f'{name}.gaze.csv').write_text('time_s,x_px,y_px\n' + rows + '\n')
    (folder / f'{name}.targets.csv').write_text(
        'onset_s,x_px,y_px\n' + '\n'.join(f'{step_s * k},{x},{y}' for k, (x, y) in
                                          enumerate(places)) + '\n')
