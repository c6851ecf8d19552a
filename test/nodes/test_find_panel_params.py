"""The file find_panel writes is a parameter file marker_projector takes after the defaults."""

import os

from domain_coordinator import domain_id
import numpy as np
from PIL import Image
import pytest
import rclpy
from rclpy.context import Context

from eye_bci_ros2.nodes.marker_projector import MarkerProjector
from eye_bci_ros2.projection.panel_finder import RVIZ_BACKGROUND
from eye_bci_ros2.tools import find_panel

pytestmark = pytest.mark.ros

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DEFAULTS = os.path.join(REPO, 'config', 'eye_bci.yaml')


@pytest.mark.parametrize('scale, expected', [
    (1.0, ([401.0, 233.0], 1042, 586)),
    (2.0, ([200.5, 116.5], 521, 293)),   # a HiDPI capture, gaze in logical px
])
def test_panel_file_loads_after_the_defaults(tmp_path, capsys, scale, expected):
    screen = np.full((1080, 1920, 3), 230, np.uint8)
    screen[233:233 + 586, 401:401 + 1042] = RVIZ_BACKGROUND
    screenshot, output = tmp_path / 'screen.png', tmp_path / 'panel.yaml'
    Image.fromarray(screen).save(screenshot)
    assert find_panel.main([str(screenshot), '--scale', str(scale), '-o', str(output)]) == 0
    with domain_id() as domain:
        context = Context()
        rclpy.init(context=context, domain_id=domain, args=[
            '--ros-args', '--params-file', DEFAULTS, '--params-file', str(output)])
        try:
            node = MarkerProjector(context=context)
            offset, width, height = expected
            assert node.camera.screen_offset.tolist() == offset
            assert node.get_parameter('image_width').value == width
            assert node.get_parameter('image_height').value == height
            assert node.get_parameter('fov_y_deg').value == 45.0   # the defaults still apply
            node.destroy_node()
        finally:
            context.try_shutdown()
