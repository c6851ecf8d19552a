"""
Node ``ssvep_stimulus``: flicker the offered options' screen regions for SSVEP.

Subscribes ``choices/regions`` (visualization_msgs/MarkerArray, latched:
the options' outlines in ``screen`` px and labels) and ``ssvep/stimuli``
(sensor_msgs/JointState, latched: each option's frequency and phase, stamp =
epoch, :mod:`eye_bci_ros2.ros.ssvep_messages`), and draws one patch per
option in a pyglet window (:class:`eye_bci_ros2.nodes.ssvep_stimulus.window.StimulusWindow`)
at every display refresh, frame k of the epoch showing ``L(k) = 0.5 (1 +
sin(2 pi f k / refresh + phase))``.  Options without a stimulus stay dark.

The window lives in the main thread (pyglet needs it); the executor spins in
a second thread and hands the latest regions and stimuli over under a lock.
Dropped frames (a flip later than 1.5 refresh periods after the previous)
are logged with their count; only a real monitor with vsync shows whether
flips land on retraces.

Photosensitivity: flicker at these frequencies can trigger seizures in
people with photosensitive epilepsy.  The node draws nothing unless started
with ``-p accept_flicker:=true`` (after the person and the experimenter have
read :data:`PHOTOSENSITIVITY_WARNING`), and logs the warning at every start.
"""

import os
import threading
from typing import Any, Dict, Optional

from rclpy.node import Node
from sensor_msgs.msg import JointState
from visualization_msgs.msg import MarkerArray

from eye_bci_ros2.ros.conversions import marker_array_to_regions
from eye_bci_ros2.ros.log_throttle import KeyedWarnings
from eye_bci_ros2.ros.parameters import declare_parameters, ParamSpec
from eye_bci_ros2.ros.runner import spin_node, StartError
from eye_bci_ros2.ros.ssvep_messages import msg_to_stimulus_map
from eye_bci_ros2.ros.topics import LATCHED_QOS, REGIONS_TOPIC, SSVEP_STIMULI_TOPIC
from eye_bci_ros2.ssvep.stimuli import StimulusMap


#: Said before any flicker, and when the opt-in is missing.
PHOTOSENSITIVITY_WARNING = (
    'ssvep_stimulus flickers screen regions at several Hz, which can trigger seizures in '
    'people with photosensitive epilepsy; use it only with their informed consent and '
    'stop it (Ctrl-C, or close the window) at any discomfort')
#: The parameter that opts in to the flicker.
ACCEPT_FLICKER = 'accept_flicker'

PARAMETERS = (
    ParamSpec(ACCEPT_FLICKER, False, 'Opt in to the flicker after reading the photosensitivity '
              'warning (--help); false = refuse to start', read_only=True),
    ParamSpec('refresh_hz', 60.0, "the display's refresh rate, Hz (frame k = epoch + k / "
              'refresh)', value_range=(1.0, 1000.0), read_only=True),
    ParamSpec('width', 0, 'window width, px (0 = fullscreen)', value_range=(0, 16384),
              read_only=True),
    ParamSpec('height', 0, 'window height, px (0 = fullscreen)', value_range=(0, 16384),
              read_only=True),
    ParamSpec('origin_x', 0.0, "screen px of the window's left edge", value_range=(-1e5, 1e5),
              read_only=True),
    ParamSpec('origin_y', 0.0, "screen px of the window's top edge", value_range=(-1e5, 1e5),
              read_only=True),
    ParamSpec('gamma', 1.0, 'display gamma; gray = 255 L^(1/gamma)', value_range=(0.1, 5.0),
              read_only=True),
    ParamSpec('vsync', True, 'flip on the vertical retrace (a real monitor)', read_only=True),
)


class SsvepStimulus(Node):
    """Draw the SSVEP stimuli of the offered options, frame-locked."""

    def __init__(self, visible: bool = True, **kwargs):
        """Declare parameters, open the window (this thread), subscribe the topics."""
        super().__init__('ssvep_stimulus', **kwargs)
        self._params = declare_parameters(self, PARAMETERS, lambda changed: None)
        if not self._params[ACCEPT_FLICKER]:
            raise StartError(f'{PHOTOSENSITIVITY_WARNING}. To start it: --ros-args -p '
                             f'{ACCEPT_FLICKER}:=true')
        self.get_logger().warning(PHOTOSENSITIVITY_WARNING)
        fullscreen = not (self._params['width'] and self._params['height'])
        try:
            # Imported here: pyglet opens the display on import of its window module.
            from eye_bci_ros2.nodes.ssvep_stimulus.window import StimulusWindow
            self.window = StimulusWindow(
                self._params['width'] or 1, self._params['height'] or 1,
                self._params['refresh_hz'],
                (self._params['origin_x'], self._params['origin_y']),
                self._params['gamma'], self._params['vsync'], visible, fullscreen)
        except Exception as error:  # noqa: B902 - pyglet's display errors have no common base
            raise StartError(f'no display to draw the stimuli on (DISPLAY='
                             f"{os.environ.get('DISPLAY', 'unset')}): "
                             f'{type(error).__name__}: {error}') from None
        self._lock = threading.Lock()
        self._pending: Dict[str, Any] = {}
        self._warnings = KeyedWarnings(self.get_logger())
        self._reported_drops = 0
        self.create_subscription(MarkerArray, REGIONS_TOPIC, self._on_regions, LATCHED_QOS)
        self.create_subscription(JointState, SSVEP_STIMULI_TOPIC, self._on_stimuli, LATCHED_QOS)
        width, height = self.window.size
        self.get_logger().info(f'ssvep_stimulus: {width}x{height} px at '
                               f"{self._params['refresh_hz']:g} Hz")

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _warn(self, key: str, text: str) -> None:
        self._warnings.warn(key, text)

    def _on_regions(self, msg: MarkerArray) -> None:
        try:
            labels, polygons = marker_array_to_regions(msg)
            with self._lock:
                self._pending['regions'] = (labels, polygons)
        except Exception as error:  # noqa: B902 - a node never dies on a message
            self._warn('regions', f'regions message ignored: {error}')

    def _on_stimuli(self, msg: JointState) -> None:
        try:
            stimuli = msg_to_stimulus_map(msg)
        except ValueError as error:
            self._warn('stimuli', f'stimulus map ignored: {error}; options stay dark')
            stimuli = None
        if stimuli is not None and stimuli.epoch_s == 0.0:
            stimuli = StimulusMap(stimuli.labels, stimuli.frequencies, stimuli.phases,
                                  self._now())
        with self._lock:
            self._pending['stimuli'] = stimuli

    def apply_pending(self) -> None:
        """Hand what the callbacks received to the window (call in the window's thread)."""
        with self._lock:
            pending, self._pending = self._pending, {}
        if 'regions' in pending:
            self.window.set_regions(*pending['regions'])
        if 'stimuli' in pending:
            self.window.set_stimuli(pending['stimuli'])

    def render(self, now: Optional[float] = None) -> int:
        """Draw and flip the next frame (window thread); return frames dropped before it."""
        self.apply_pending()
        missed = self.window.show_next(self._now() if now is None else now)
        if missed:
            self._warn('dropped', f'dropped {missed} frame(s) before frame {self.window.frame} '
                       f'({self.window.clock.dropped} since start); the flicker skips them to '
                       f'stay phase-locked')
        return missed

    def destroy_node(self):
        """Close the window, then destroy the node."""
        if getattr(self, 'window', None) is not None:
            self.window.close()
        return super().destroy_node()


def _render_until(nodes, stop: threading.Event) -> None:
    """Draw frames in the main thread (pyglet's) until ``stop`` or the window closes."""
    node = nodes[0]
    while not stop.is_set() and not node.window.window.has_exit:
        node.render()


def main(args=None):
    """Spin the node behind the window, which draws in this thread, until Ctrl-C or closed."""
    spin_node(SsvepStimulus, args, help_modules=[__name__], foreground=_render_until)


if __name__ == '__main__':
    main()
