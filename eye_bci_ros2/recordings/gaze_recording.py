"""
A recording of gaze and the targets shown: the one form every gaze loader returns (pure).

Shared by the loaders (:mod:`eye_bci_ros2.recordings.gaze`, whose module doc
lists the formats, and :mod:`eye_bci_ros2.recordings.xdf`), so neither
imports the other's internals.
"""

from dataclasses import dataclass
import math
import os
from typing import Tuple, Union

import numpy as np

from eye_bci_ros2.projection.visual_angle import ScreenGeometry

PathLike = Union[str, os.PathLike]


@dataclass(frozen=True)
class TargetSchedule:
    """
    Where the person was asked to look, and when.

    :param onsets: (K,) s, when target k appeared (a jump) or started moving
        towards its place (a glide); ascending.
    :param still: (K,) s, from when target k is shown still at its place
        (equal to ``onsets`` for a jump).
    :param ends: (K,) s, when target k gives way to the next (the next onset;
        the last sample's stamp for the last target).
    :param places: (K, 2) screen px, each target's place.
    """

    onsets: np.ndarray
    still: np.ndarray
    ends: np.ndarray
    places: np.ndarray

    def __len__(self) -> int:
        """Return the number of targets."""
        return len(self.onsets)

    @property
    def jumps(self) -> bool:
        """Whether every target appears at its place at once (no glide)."""
        return bool(np.allclose(self.onsets, self.still))


@dataclass(frozen=True)
class GazeRecording:
    """
    One person's recorded gaze and the targets they were shown.

    :param name: the recording's name (its file name without extensions).
    :param stamps: (N,) s from the first sample, ascending.
    :param points: (N, 2) screen px; NaN where the eyes were lost.
    :param screen: the person's screen and viewing distance.
    :param targets: the target schedule, same clock as ``stamps``.
    :param tracker: what recorded it, as far as the file says (free text).
    """

    name: str
    stamps: np.ndarray
    points: np.ndarray
    screen: ScreenGeometry
    targets: TargetSchedule
    tracker: str = ''

    @property
    def rate_hz(self) -> float:
        """Nominal sample rate: 1 / the median sample interval, Hz."""
        steps = np.diff(self.stamps)
        steps = steps[steps > 0]
        return float(1.0 / np.median(steps)) if steps.size else math.nan

    @property
    def lost_share(self) -> float:
        """Fraction of the samples without gaze (blinks, lost eyes)."""
        if not len(self.points):
            return 0.0
        return float(np.mean(~np.isfinite(self.points).all(axis=1)))

    def between(self, start: float, end: float) -> Tuple[np.ndarray, np.ndarray]:
        """Return the samples stamped in [start, end): stamps (M,), points (M, 2) (views)."""
        low, high = np.searchsorted(self.stamps, [start, end], side='left')
        return self.stamps[low:high], self.points[low:high]


class RecordingError(ValueError):
    """A file that is not a gaze recording of a known format (one-line message)."""
