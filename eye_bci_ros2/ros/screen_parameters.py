"""
The person's screen, as node parameters: one table for every node that needs it.

``choice_arbiter`` (degrees -> px for the tolerant rule) and
``gaze_validation`` (accuracy in degrees) both describe the screen the gaze
is in (frame ``screen``, docs/DESIGN.md) and how far the person sits from
it.  Both declare it from the one declaration of those settings
(:data:`eye_bci_ros2.projection.visual_angle.SCREEN_SETTINGS`), so names, defaults
(:data:`eye_bci_ros2.projection.visual_angle.DEFAULT_VIEWING`), ranges and descriptions
are the same, and a params file with a ``/**:`` section sets both at once.
"""

from typing import Any, Dict, Tuple

from eye_bci_ros2.projection.visual_angle import SCREEN_SETTINGS, ScreenGeometry
from eye_bci_ros2.ros.parameters import param_specs, ParamSpec

#: The parameter names, in the order :class:`ScreenGeometry` takes them.
NAMES = tuple(setting.name for setting in SCREEN_SETTINGS)


def person_screen_parameters() -> Tuple[ParamSpec, ...]:
    """Return the rows of the person's screen (:data:`NAMES`)."""
    return param_specs(SCREEN_SETTINGS)


def person_screen(values: Dict[str, Any]) -> ScreenGeometry:
    """Return the person's screen of a node's parameter values (:data:`NAMES`)."""
    return ScreenGeometry(*(values[name] for name in NAMES))
