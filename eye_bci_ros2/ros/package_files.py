"""
Where the package's installed files are: the ament index, else the source tree.

The only place that asks the ament index (``ament_index_python``), so the pure
core stays free of ROS (docs/DESIGN.md, "Layers").
"""

import functools
from pathlib import Path
import sys
from typing import Dict, Tuple

import yaml

from eye_bci_ros2.task.scene import DEFAULT_SCENE_NAME

#: The ROS package name (its share directory holds the installed config/).
PACKAGE_NAME = 'eye_bci_ros2'


def config_file(name: str) -> str:
    """
    Locate ``config/<name>`` of the package.

    Tries the installed share directory (ament index), then the source tree
    next to this package (``pip install -e``), then ``<prefix>/share``.

    :raises ValueError: none of these exists.
    """
    candidates = []
    try:
        from ament_index_python.packages import get_package_share_directory
        candidates.append(Path(get_package_share_directory(PACKAGE_NAME)) / 'config')
    except (ImportError, LookupError, OSError, ValueError):
        pass  # not in an ament index: a plain pip install or a source checkout
    candidates.append(Path(__file__).resolve().parents[2] / 'config')
    candidates.append(Path(sys.prefix) / 'share' / PACKAGE_NAME / 'config')
    for directory in candidates:
        path = directory / name
        if path.is_file():
            return str(path)
    raise ValueError(f'{name} not found in: ' + ', '.join(str(d) for d in candidates))


def default_scene_path() -> str:
    """Locate the default ``config/scene.yaml`` (:func:`config_file`)."""
    try:
        return config_file(DEFAULT_SCENE_NAME)
    except ValueError as error:
        raise ValueError(f'default scene {error}') from None


#: The defaults file of every node (``tools/describe.py --yaml`` writes it from the nodes).
DEFAULTS_FILE = 'eye_bci.yaml'


@functools.lru_cache(maxsize=1)
def package_parameters() -> Dict[str, Tuple[str, ...]]:
    """
    Return every node's parameter names, ``{node: names}``, from the defaults file.

    For the hint on a parameter name a node does not have: another node of the
    package may (``-p screen_offset_x`` is marker_projector's, not the bridge's).
    Empty when the file cannot be read (the hint then names this node's only).
    """
    try:
        with open(config_file(DEFAULTS_FILE), encoding='utf-8') as stream:
            data = yaml.safe_load(stream) or {}
        return {node.lstrip('/'): tuple((entry or {}).get('ros__parameters') or ())
                for node, entry in data.items()}
    except (OSError, ValueError, AttributeError, yaml.YAMLError):
        return {}
