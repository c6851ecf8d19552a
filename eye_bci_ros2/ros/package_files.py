"""
Where the package's installed files are: the ament index, else the source tree.

The only place that asks the ament index (``ament_index_python``), so the pure
core stays free of ROS (docs/DESIGN.md, "Layers").
"""

from pathlib import Path
import sys

from eye_bci_ros2.task.scene import DEFAULT_SCENE_NAME

#: The ROS package name (its share directory holds the installed config/).
PACKAGE_NAME = 'eye_bci_ros2'


def default_scene_path() -> str:
    """
    Locate the default ``config/scene.yaml``.

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
        path = directory / DEFAULT_SCENE_NAME
        if path.is_file():
            return str(path)
    raise ValueError(f'default scene {DEFAULT_SCENE_NAME} not found in: '
                     + ', '.join(str(d) for d in candidates))
