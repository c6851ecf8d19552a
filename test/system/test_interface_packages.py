"""
The interface packages of ``interfaces/`` never shadow the real ones in a user's colcon build.

They are copies of nav2_msgs, tf2_msgs and rviz_plugin_view_animated_msgs for the PyPI
set-up (``interfaces/build.sh`` names each package with ``--paths``).  A ROS user whose
workspace holds this repository must get only eye_bci_ros2 from ``colcon build``, with the
real interface packages from apt: colcon does not descend into a package (the repository
root), and ``interfaces/COLCON_IGNORE`` keeps a crawl of the folder itself out.  Checked
with the venv's colcon package discovery, as ``colcon build`` runs it.
"""

import argparse
import shutil

from colcon_core.package_discovery import add_package_discovery_arguments, discover_packages
from colcon_core.package_identification import get_package_identification_extensions
from paths import REPO

INTERFACES = REPO / 'interfaces'
COPIES = ['nav2_msgs', 'rviz_plugin_view_animated_msgs', 'tf2_msgs']


def discovered(*arguments) -> list:
    """Return the names of the packages colcon finds with these discovery arguments."""
    parser = argparse.ArgumentParser()
    add_package_discovery_arguments(parser)
    descriptors = discover_packages(parser.parse_args([str(a) for a in arguments]),
                                    get_package_identification_extensions())
    return sorted(descriptor.name for descriptor in descriptors)


def test_a_workspace_holding_the_repository_builds_only_eye_bci_ros2(tmp_path):
    assert discovered('--base-paths', REPO) == ['eye_bci_ros2']
    assert discovered('--base-paths', INTERFACES) == []
    # The folder alone in a workspace (copied out of the package): still ignored.
    shutil.copytree(INTERFACES, tmp_path / 'src' / 'interfaces')
    assert discovered('--base-paths', tmp_path / 'src') == []


def test_the_set_up_names_each_interface_package():
    # interfaces/build.sh: --paths with each folder holding a package.xml.
    folders = [manifest.parent for manifest in sorted(INTERFACES.glob('*/package.xml'))]
    assert discovered('--paths', *folders) == COPIES
