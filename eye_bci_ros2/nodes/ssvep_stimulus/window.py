"""
The SSVEP stimulus window: flickering patches over the options' screen regions (pyglet).

RViz2 draws at its own frame rate (30 fps by default) and cannot flicker
frame-exactly, so a separate borderless window (on top of RViz, fullscreen
on the display the person looks at) draws one patch per offered option: the
option's region (convex polygon, ``screen`` px, from ``choices/regions``),
filled with the gray level of its sampled sinusoid at the frame being shown,
``L(k) = 0.5 (1 + sin(2 pi f k / refresh + phase))``
(:func:`eye_bci_ros2.ssvep.stimuli.luminance`), k counted from the stimulus
epoch.  Everything else is black (``background``).  Gray value =
``round(255 * L ** (1 / gamma))`` (gamma 1 = linear framebuffer values;
measure the monitor and set its gamma for linear luminance).

What only a real monitor shows: that flips land on retraces (vsync), the
true refresh rate, and whether frames are dropped.  The window asks for
vsync, measures its flip times and logs dropped frames
(:class:`eye_bci_ros2.ssvep.frame_clock.FrameClock`); under Xvfb there is no
retrace, so the tests check the frames' content, not their timing.
"""

import logging
from typing import Optional, Sequence

import numpy as np
import pyglet
from pyglet import shapes

from eye_bci_ros2.ssvep.frame_clock import FrameClock
from eye_bci_ros2.ssvep.stimuli import luminance, StimulusMap

_LOG = logging.getLogger(__name__)


class StimulusWindow:
    """
    A pyglet window drawing the SSVEP patches frame by frame.

    :param width: window width, px; ``height`` likewise.
    :param refresh_hz: the display's refresh rate, Hz.
    :param origin: screen px of the window's top-left corner (0, 0 fullscreen).
    :param gamma: display gamma (1 = write L linearly).
    :param vsync: wait for the retrace at each flip (a real monitor).
    :param visible: show the window (False for off-screen tests).
    """

    def __init__(self, width: int, height: int, refresh_hz: float = 60.0,
                 origin: Sequence[float] = (0.0, 0.0), gamma: float = 1.0,
                 vsync: bool = True, visible: bool = True, fullscreen: bool = False):
        self.refresh_hz = float(refresh_hz)
        self.origin = np.asarray(origin, dtype=float)
        self.gamma = float(gamma)
        if fullscreen:
            self.window = pyglet.window.Window(fullscreen=True, vsync=vsync, visible=visible,
                                               caption='ssvep stimulus')
        else:
            self.window = pyglet.window.Window(int(width), int(height), vsync=vsync,
                                               visible=visible, style='borderless',
                                               caption='ssvep stimulus')
        self.clock = FrameClock(self.refresh_hz)
        self._batch = pyglet.graphics.Batch()
        self._patches = []
        self._labels: tuple = ()
        self._polygons = np.zeros((0, 3, 2))
        self._stimuli: Optional[StimulusMap] = None
        #: Frame index of the last frame drawn.
        self.frame = 0
        #: Frames drawn since start.
        self.frames_drawn = 0

    @property
    def size(self):
        """Return the framebuffer width and height, px."""
        return self.window.get_framebuffer_size()

    def set_regions(self, labels: Sequence[str], polygons: np.ndarray) -> None:
        """
        Place the patches: one per region.

        :param labels: option labels (R,).
        :param polygons: shape (R, K, 2), screen px (y down), convex, padded.
        """
        self._labels = tuple(labels)
        self._polygons = np.asarray(polygons, dtype=float).reshape(len(labels), -1, 2)
        self._rebuild()

    def set_stimuli(self, stimuli: Optional[StimulusMap]) -> None:
        """Use a stimulus map; its epoch (s, on the clock passed to draw) is frame 0."""
        self._stimuli = stimuli
        if stimuli is not None:
            self.clock.restart(stimuli.epoch_s)

    def _rebuild(self) -> None:
        for patch in self._patches:
            patch.delete()
        self._patches = []
        height = self.size[1]
        for polygon in self._polygons:
            points = polygon - self.origin
            # Screen y runs down, OpenGL's up.
            vertices = [(float(x), float(height - y)) for x, y in _distinct(points)]
            patch = shapes.Polygon(*vertices, color=(0, 0, 0), batch=self._batch)
            self._patches.append(patch)

    def gray_levels(self, frame: int) -> np.ndarray:
        """Gray value 0-255 of each patch at ``frame`` (0 without a stimulus), shape (R,)."""
        levels = np.zeros(len(self._labels), dtype=int)
        if self._stimuli is None:
            return levels
        known = [i for i, label in enumerate(self._labels) if label in self._stimuli.labels]
        if not known:
            return levels
        stimuli = [self._stimuli.stimulus(self._labels[i]) for i in known]
        values = luminance([frame], [f for f, _ in stimuli], [p for _, p in stimuli],
                           self.refresh_hz)[0]
        levels[known] = np.rint(255.0 * values ** (1.0 / self.gamma)).astype(int)
        return levels

    def draw(self, frame: int) -> None:
        """Draw ``frame`` into the back buffer (no flip)."""
        self.frame = int(frame)
        for patch, level in zip(self._patches, self.gray_levels(frame)):
            patch.color = (int(level),) * 3
        self.window.switch_to()
        pyglet.gl.glClearColor(0.0, 0.0, 0.0, 1.0)
        self.window.clear()
        self._batch.draw()
        self.frames_drawn += 1

    def show_next(self, now: float) -> int:
        """
        Draw the frame due at the next retrace after ``now`` and flip; log dropped frames.

        :param now: time on the stimulus clock (the epoch's clock), s.
        :returns: frames dropped before this flip.
        """
        self.window.dispatch_events()
        self.draw(self.clock.frame_at(now) + 1)
        self.window.flip()
        missed = self.clock.flipped(now)
        if missed:
            _LOG.warning('stimulus window dropped %d frame(s) before frame %d (%d in all): '
                         'the flicker skipped them to stay phase-locked', missed, self.frame,
                         self.clock.dropped)
        return missed

    def read_pixels(self) -> np.ndarray:
        """Read the back buffer as drawn: (height, width, 3) uint8, row 0 at the top."""
        buffer = pyglet.image.get_buffer_manager().get_color_buffer().get_image_data()
        data = np.frombuffer(buffer.get_data('RGB', buffer.width * 3), dtype=np.uint8)
        return data.reshape(buffer.height, buffer.width, 3)[::-1]

    def close(self) -> None:
        """Close the window."""
        self.window.close()


def _distinct(polygon: np.ndarray) -> np.ndarray:
    """Drop repeated vertices (the padding of short outlines) and a closing vertex."""
    keep = np.ones(len(polygon), dtype=bool)
    keep[1:] = np.any(np.abs(np.diff(polygon, axis=0)) > 1e-9, axis=1)
    polygon = polygon[keep]
    if len(polygon) > 3 and np.allclose(polygon[0], polygon[-1]):
        polygon = polygon[:-1]
    return polygon
