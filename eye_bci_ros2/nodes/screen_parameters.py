"""
The person's screen, as node parameters: one table for every node that needs it.

``choice_arbiter`` (degrees -> px for the tolerant rule) and
``gaze_validation`` (accuracy in degrees) both describe the screen the gaze
is in (frame ``screen``, docs/DESIGN.md) and how far the person sits from
it.  They declare it from :func:`person_screen_parameters`, so names,
defaults (:data:`eye_bci_ros2.projection.visual_angle.DEFAULT_VIEWING`), ranges and
descriptions are the same, and a params file with a ``/**:`` section sets
both at once.
"""

from typing import Any, Dict, Tuple

from eye_bci_ros2.nodes.parameters import ParamSpec
from eye_bci_ros2.projection.visual_angle import DEFAULT_VIEWING, ScreenGeometry

#: Largest screen side, px (16K).
MAX_SIDE_PX = 16384
#: Screen sides from 1 cm to 10 m, mm.
SIDE_MM_RANGE = (10.0, 10000.0)
#: Eye to screen centre from 5 cm to 10 m, mm.
DISTANCE_MM_RANGE = (50.0, 10000.0)
#: The parameter names, in the order :class:`ScreenGeometry` takes them.
NAMES = ('screen_width', 'screen_height', 'screen_width_mm', 'screen_height_mm',
         'viewing_distance_mm')


def person_screen_parameters() -> Tuple[ParamSpec, ...]:
    """Return the rows of the person's screen (:data:`NAMES`)."""
    return (
        ParamSpec('screen_width', DEFAULT_VIEWING.width_px,
                  "The person's screen, the one the gaze is in (frame screen): width, px",
                  value_range=(1, MAX_SIDE_PX)),
        ParamSpec('screen_height', DEFAULT_VIEWING.height_px,
                  "The person's screen: height, px", value_range=(1, MAX_SIDE_PX)),
        ParamSpec('screen_width_mm', DEFAULT_VIEWING.width_mm,
                  "The person's screen: visible width, mm (degrees <-> px)",
                  value_range=SIDE_MM_RANGE),
        ParamSpec('screen_height_mm', DEFAULT_VIEWING.height_mm,
                  "The person's screen: visible height, mm", value_range=SIDE_MM_RANGE),
        ParamSpec('viewing_distance_mm', DEFAULT_VIEWING.distance_mm,
                  "Distance from the person's eyes to the screen centre, mm",
                  value_range=DISTANCE_MM_RANGE),
    )


def person_screen(values: Dict[str, Any]) -> ScreenGeometry:
    """Return the person's screen of a node's parameter values (:data:`NAMES`)."""
    return ScreenGeometry(*(values[name] for name in NAMES))
