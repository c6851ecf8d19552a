"""
The ``rviz_config`` parameter shared by camera_tracker and marker_projector.

``rviz_config`` names an RViz2 ``.rviz`` file (``''`` = none), read once at
start-up (the parameter is read-only).  Precedence, the same in every node: a
parameter at its built-in default takes the file's value; a parameter set to
anything else (command line, ``--params-file``, ``ros2 param set``) wins over
the file.  So config/eye_bci.yaml, which holds the defaults, does not hide an
``rviz_config``.
"""

from functools import lru_cache
from typing import Any, Dict, Optional

from eye_bci_ros2.projection.rviz_config import read_rviz_config, RvizView
from eye_bci_ros2.ros.parameters import ParamSpec


def rviz_config_spec(uses: str) -> ParamSpec:
    """Return the ``rviz_config`` parameter of a node; ``uses`` says what the node takes."""
    return ParamSpec('rviz_config', '',
                     f"Path of an RViz2 .rviz file ('' = none; read once at start-up): {uses}. "
                     'A parameter set away from its default wins over the file.',
                     read_only=True)


@lru_cache(maxsize=16)
def _read(path: str) -> RvizView:
    """Read an .rviz file once per path."""
    return read_rviz_config(path)


def rviz_view(values: Dict[str, Any]) -> Optional[RvizView]:
    """
    Return the view of the node's ``rviz_config`` file, or None when it names none.

    :param values: the node's parameters (``rviz_config``, ``world_frame``).
    :raises ValueError: an unreadable or unusable file (see
        :func:`eye_bci_ros2.projection.rviz_config.read_rviz_config`), or one whose fixed
        frame is not ``world_frame``.
    """
    path = values.get('rviz_config') or ''
    if not path:
        return None
    view = _read(path)
    if view.fixed_frame != values['world_frame']:
        raise ValueError(f"rviz_config '{path}' has Fixed Frame '{view.fixed_frame}' but "
                         f"world_frame is '{values['world_frame']}': set "
                         f'world_frame:={view.fixed_frame}')
    return view


def at_default(values: Dict[str, Any], specs, *names: str) -> bool:
    """Tell whether every named parameter is at its built-in default (so the file may decide)."""
    defaults = {spec.name: spec.default for spec in specs}
    return all(values[name] == defaults[name] for name in names)
