"""
When invalid gaze samples are worth a warning: only when the user must fix something.

A tracker sends invalid samples all the time for normal reasons: a blink
(NaN for 0.1-0.4 s), a glance away from the screen (off-screen for a few
seconds), a moment of low confidence.  The bridge counts them per reason in
its periodic statistics line; this module decides when they mean that
something must be done, and says what:

* every sample since the stream started is invalid: the layout (profile,
  ``x_channel`` / ``y_channel``, units, screen size) does not describe the
  stream, or the tracker never found the eyes;
* nothing valid for ``limit_s`` after valid gaze: the tracker lost the eyes,
  or the person has looked away for that long.

One warning per such stretch, and one line when valid gaze is back.  Time
is the samples' own stamps (ns), so a stream that sends nothing is the
connection's "stale" case, not this one.
"""

from typing import Dict, NamedTuple, Optional

import numpy as np


class Report(NamedTuple):
    """A line for the log: a warning (the user must act) or news (valid gaze is back)."""

    warning: bool
    text: str


class InvalidGazeWatch:
    """Follow the valid and invalid samples of one stream; say when to warn."""

    def __init__(self, limit_s: float):
        """
        Warn after ``limit_s`` of invalid samples only.

        :param limit_s: seconds of sample time with no valid sample before a warning.
        """
        self.limit_s = limit_s
        self.reset()

    def reset(self) -> None:
        """Start over (a new stream, or a new layout for it)."""
        self._valid_seen = False
        # Stamp of the first invalid sample after the last valid one, ns (None: none yet).
        self._since_ns: Optional[int] = None
        self._counts: Dict[str, int] = {}
        self._warned = False

    def update(self, stamps_ns: np.ndarray, keep: np.ndarray,
               dropped: Dict[str, int]) -> Optional[Report]:
        """
        Take one converted chunk; return a line to log, or None.

        :param stamps_ns: shape (N,), int: each sample's stamp, ns, ascending.
        :param keep: shape (N,), bool: the sample is valid (published).
        :param dropped: invalid samples of the chunk per reason.
        :returns: a warning when a stretch of invalid gaze needs the user, news
            when valid gaze is back after such a warning, else None.
        """
        if not len(stamps_ns):
            return None
        if keep.any():
            valid = np.flatnonzero(keep)
            first_valid, last_valid = int(valid[0]), int(valid[-1])
            line = None
            if self._warned:
                line = Report(False, 'valid gaze again after '
                              f'{(int(stamps_ns[first_valid]) - self._since_ns) * 1e-9:.1f} s')
            self._valid_seen = True
            self._warned = False
            self._counts = {}
            tail = ~keep[last_valid + 1:]
            self._since_ns = int(stamps_ns[last_valid + 1]) if tail.any() else None
            return line
        if self._since_ns is None:
            self._since_ns = int(stamps_ns[0])
        for reason, number in dropped.items():
            self._counts[reason] = self._counts.get(reason, 0) + number
        length_s = (int(stamps_ns[-1]) - self._since_ns) * 1e-9
        if self._warned or length_s < self.limit_s:
            return None
        self._warned = True
        reasons = ', '.join(f'{number} {reason}'
                            for reason, number in self._counts.items() if number)
        if not self._valid_seen:
            return Report(True, f'no valid gaze sample since the stream started ({reasons} in '
                                f'{length_s:.1f} s): check that profile, x_channel, y_channel, '
                                'units and the screen size describe this stream, and that the '
                                'tracker sees the eyes')
        return Report(True, f'no valid gaze for {length_s:.1f} s ({reasons}): the tracker has '
                            'lost the eyes or the person looks away from the screen')
