"""config/eye_bci.rviz: the default scene's RViz2 setup reads back as the nodes' defaults."""

from pathlib import Path

import numpy as np
import yaml

from eye_bci_ros2.navigation.frames import MAP_FRAME
from eye_bci_ros2.nodes.camera_tracker import DEFAULT_EYE, DEFAULT_FOCUS, DEFAULT_UP
from eye_bci_ros2.nodes.marker_projector import PARAMETERS as PROJECTOR_PARAMETERS
from eye_bci_ros2.projection.rviz_config import read_rviz_config
from eye_bci_ros2.ros import topics

CONFIG = Path(__file__).resolve().parents[2] / 'config' / 'eye_bci.rviz'


def test_view_reads_back_as_camera_trackers_default_static_view():
    view = read_rviz_config(CONFIG)
    assert view.controller == 'rviz_default_plugins/Orbit'
    assert view.projection == 'perspective'
    assert view.fixed_frame == 'map'
    np.testing.assert_allclose(view.eye, DEFAULT_EYE, atol=1e-9)
    np.testing.assert_allclose(view.focus, DEFAULT_FOCUS, atol=1e-9)
    np.testing.assert_allclose(view.up, DEFAULT_UP)


def test_window_state_holds_the_default_1280x720_panel():
    defaults = {spec.name: spec.default for spec in PROJECTOR_PARAMETERS}
    assert read_rviz_config(CONFIG).panel_size == (1280, 720)
    assert (defaults['image_width'], defaults['image_height']) == (1280, 720)


def test_displays_show_what_the_person_must_see():
    document = yaml.safe_load(CONFIG.read_text())
    displays = {d['Topic']['Value']: d for d in document['Visualization Manager']['Displays']
                if d['Class'] == 'rviz_default_plugins/MarkerArray'}
    assert set(displays) == {'/choices', '/choices/feedback', '/choices/regions',
                             '/validation/targets', '/robot/marker'}
    assert displays['/choices']['Enabled'] is True
    # The choices are latched (transient local): RViz must ask for them the same way.
    assert displays['/choices']['Topic']['Durability Policy'] == 'Transient Local'
    assert displays['/choices/feedback']['Enabled'] is True
    # The validation targets are latched too, and shown whenever a validation runs.
    assert displays['/validation/targets']['Enabled'] is True
    assert displays['/validation/targets']['Topic']['Durability Policy'] == 'Transient Local'
    assert displays['/choices/regions']['Enabled'] is False   # a check display only
    classes = [d['Class'] for d in document['Visualization Manager']['Displays']]
    assert 'rviz_default_plugins/Grid' in classes


def test_displays_show_the_robot_its_map_and_its_plan_with_the_publishers_qos():
    document = yaml.safe_load(CONFIG.read_text())
    displays = {d['Topic']['Value']: d for d in document['Visualization Manager']['Displays']
                if 'Topic' in d}
    expected = {topics.MAP_TOPIC: ('rviz_default_plugins/Map', topics.MAP_QOS),
                topics.PLAN_TOPIC: ('rviz_default_plugins/Path', topics.PLAN_QOS),
                topics.ROBOT_MARKER_TOPIC: ('rviz_default_plugins/MarkerArray',
                                            topics.ROBOT_MARKER_QOS)}
    for topic, (kind, qos) in expected.items():
        display = displays['/' + topic]
        assert display['Class'] == kind and display['Enabled'] is True, topic
        # A latched publisher is seen by a display that asks for transient local (the map
        # is published once); a volatile one by a volatile display.
        durability = display['Topic']['Durability Policy'].replace(' ', '_').upper()
        assert durability == qos.durability.name, topic
        assert display['Topic']['Reliability Policy'].upper() == qos.reliability.name, topic


def test_the_robot_is_shown_through_tf_in_the_map_frame_and_the_plan_with_headings():
    document = yaml.safe_load(CONFIG.read_text())
    manager = document['Visualization Manager']
    assert manager['Global Options']['Fixed Frame'] == MAP_FRAME
    (tf_display,) = [d for d in manager['Displays'] if d['Class'] == 'rviz_default_plugins/TF']
    assert tf_display['Enabled'] is True and tf_display['Frames']['All Enabled'] is True
    plan = [d for d in manager['Displays'] if d['Class'] == 'rviz_default_plugins/Path'][0]
    assert plan['Pose Style'] == 'Arrows'
