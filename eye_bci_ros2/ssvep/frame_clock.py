"""
Frame-locked timing of the SSVEP stimulus: which display frame is due, and dropped frames.

Frame k of a stimulus with epoch t0 is shown at ``t0 + k / refresh``.  After
each buffer flip (which blocks until the vertical retrace with vsync on) the
window calls :meth:`FrameClock.flipped` with the flip time; the next frame
drawn is the one due at the next retrace, so a late flip skips the frames it
missed (the flicker stays phase-locked to the epoch) and counts them as
dropped.  Only a real monitor with vsync makes flips land on retraces;
under Xvfb (no retrace) the frame index follows the clock the same way.
"""

import math
from typing import Optional


class FrameClock:
    """
    Count display frames from the stimulus epoch.

    :param refresh_hz: display refresh rate, Hz.
    :param epoch_s: time of frame 0, s (the stimulus map's epoch).
    :param late_fraction: a flip later than (1 + this) frame periods after the
        previous one has dropped frames.
    """

    def __init__(self, refresh_hz: float, epoch_s: float = 0.0, late_fraction: float = 0.5):
        if not (math.isfinite(refresh_hz) and refresh_hz > 0):
            raise ValueError(f'refresh rate must be > 0 Hz, got {refresh_hz}')
        self.period_s = 1.0 / float(refresh_hz)
        self.late_fraction = float(late_fraction)
        self.epoch_s = float(epoch_s)
        self.dropped = 0
        self._last: Optional[float] = None

    def restart(self, epoch_s: float) -> None:
        """Start counting from a new epoch (a new stimulus map)."""
        self.epoch_s = float(epoch_s)
        self._last = None

    def frame_at(self, t: float) -> int:
        """Return the frame due at time ``t`` (the nearest retrace), may be negative."""
        return int(round((t - self.epoch_s) / self.period_s))

    def flipped(self, t: float) -> int:
        """
        Record a flip at time ``t``; return how many frames were dropped before it.

        :returns: 0 on time, else the frames skipped since the previous flip.
        """
        missed = 0
        if self._last is not None:
            elapsed = t - self._last
            if elapsed > (1.0 + self.late_fraction) * self.period_s:
                missed = int(round(elapsed / self.period_s)) - 1
        self._last = t
        self.dropped += missed
        return missed
