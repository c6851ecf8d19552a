"""The SSVEP stimulus window under Xvfb: each patch's gray level per frame, patch places."""

import numpy as np
import pytest

from eye_bci_ros2.ssvep.stimuli import assign_stimuli, luminance


WIDTH, HEIGHT = 640, 360


@pytest.fixture
def window(xvfb):
    from eye_bci_ros2.nodes.ssvep_stimulus.window import StimulusWindow
    win = StimulusWindow(WIDTH, HEIGHT, refresh_hz=60.0, origin=(100.0, 50.0), vsync=False)
    yield win
    win.close()


def _square(x, y, half=40.0):
    return [[x - half, y - half], [x + half, y - half], [x + half, y + half],
            [x - half, y + half], [x - half, y - half]]


def test_each_patch_shows_its_sampled_sinusoid_frame_by_frame(window):
    labels = ('kitchen', 'bedroom', 'office')
    centres = [(200.0, 150.0), (400.0, 150.0), (600.0, 300.0)]  # screen px
    window.set_regions(labels, np.array([_square(x, y) for x, y in centres]))
    stimuli = assign_stimuli(labels, frequencies=(8.0, 10.0, 12.0))
    window.set_stimuli(stimuli)
    expected = np.rint(255 * luminance(np.arange(60), stimuli.frequencies, stimuli.phases,
                                       60.0)).astype(int)
    measured = []
    for frame in range(60):
        window.draw(frame)
        pixels = window.read_pixels()
        # Window px = screen px - origin (100, 50).
        measured.append([int(pixels[int(y) - 50, int(x) - 100, 0]) for x, y in centres])
        assert pixels[5, 5].tolist() == [0, 0, 0]  # outside every patch: background
    np.testing.assert_allclose(np.array(measured), expected, atol=1)
    assert window.frames_drawn == 60


def test_patches_cover_their_regions_only(window):
    window.set_regions(('a',), np.array([_square(300.0, 200.0, 50.0)]))
    window.set_stimuli(assign_stimuli(['a'], frequencies=(15.0,), phase_step=0.0))
    window.draw(1)  # L = 0.5 (1 + sin(pi/2)) = 1: white
    pixels = window.read_pixels()[..., 0]
    lit = np.argwhere(pixels > 128)
    top, left = lit.min(axis=0)
    bottom, right = lit.max(axis=0)
    # The square spans screen x 250..350, y 150..250: window x 150..250, y 100..200.
    assert abs(left - 150) <= 1 and abs(right - 249) <= 1
    assert abs(top - 100) <= 1 and abs(bottom - 199) <= 1


def test_options_without_a_stimulus_stay_dark_and_dropped_frames_are_counted(window):
    window.set_regions(('a', 'b'), np.array([_square(200.0, 150.0), _square(400.0, 150.0)]))
    window.set_stimuli(assign_stimuli(['a'], frequencies=(15.0,), phase_step=0.0))
    window.draw(1)
    assert window.gray_levels(1).tolist() == [255, 0]
    clock = window.clock
    clock.restart(0.0)
    for t in (0.0, 1 / 60, 4 / 60):
        window.show_next(t)
    assert clock.dropped == 2
