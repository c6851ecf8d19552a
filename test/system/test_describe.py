"""The defaults file and docs/parameters.md's tables match what the nodes declare."""

import os

from domain_coordinator import domain_id
import paths
import pytest
import rclpy
from rclpy.context import Context

from eye_bci_ros2.tools import describe

REPO = str(paths.REPO)
CONFIG = os.path.join(REPO, 'config', 'eye_bci.yaml')
#: Where the generated parameter tables are (the README links to it).
PARAMETER_TABLES = os.path.join(REPO, 'docs', 'parameters.md')


@pytest.fixture(scope='module')
def described():
    with domain_id() as domain:
        return describe.describe_nodes(domain)


@pytest.mark.ros
def test_config_file_is_the_declared_defaults(described):
    with open(CONFIG) as stream:
        assert stream.read() == describe.to_yaml(described), \
            'config/eye_bci.yaml is stale: python -m eye_bci_ros2.tools.describe --yaml'


@pytest.mark.ros
def test_parameter_tables_are_the_declared_parameters(described):
    with open(PARAMETER_TABLES) as stream:
        document = stream.read()
    for block in describe.to_markdown(described).split('\n\n'):
        assert block.strip() in document, \
            f'docs/parameters.md parameter table is stale:\n{block}\n' \
            '(python -m eye_bci_ros2.tools.describe --markdown)'


@pytest.mark.ros
def test_config_file_loads_as_ros_params_file():
    """``--params-file config/eye_bci.yaml`` is accepted by rcl and sets the values."""
    from eye_bci_ros2.nodes.marker_projector import MarkerProjector
    with domain_id() as domain:
        context = Context()
        rclpy.init(context=context, domain_id=domain,
                   args=['--ros-args', '--params-file', CONFIG,
                         '-p', 'marker_projector:screen_offset_x:=64'])
        try:
            node = MarkerProjector(context=context)
            assert node.get_parameter('image_width').value == 1280
            assert node.get_parameter('screen_offset_x').value == 64
            node.destroy_node()
        finally:
            context.try_shutdown()
