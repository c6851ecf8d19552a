"""Frame-locked stimulus timing: due frames and dropped frames."""

import pytest

from eye_bci_ros2.ssvep.frame_clock import FrameClock


def test_frames_from_the_epoch_and_dropped_frames():
    clock = FrameClock(60.0, epoch_s=10.0)
    assert clock.frame_at(10.0) == 0 and clock.frame_at(11.0) == 60
    assert clock.frame_at(10.0 + 2.4 / 60) == 2
    flips = [10.0 + k / 60 for k in (0, 1, 2, 5, 6)]
    assert [clock.flipped(t) for t in flips] == [0, 0, 0, 2, 0]
    assert clock.dropped == 2
    clock.restart(20.0)
    assert clock.flipped(20.5) == 0 and clock.frame_at(20.5) == 30


def test_bad_refresh():
    with pytest.raises(ValueError, match='refresh'):
        FrameClock(0.0)
