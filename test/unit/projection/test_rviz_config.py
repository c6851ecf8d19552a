"""Reading .rviz files: every RViz2 view controller, the panel size, clear errors (pure)."""

import math
import textwrap

import numpy as np
import pytest

from eye_bci_ros2.projection import geometry
from eye_bci_ros2.projection.camera_model import (optical_pose_from_ogre, OrthographicCamera,
                                                  RvizCamera)
from eye_bci_ros2.projection.rviz_config import (decode_window_state, encode_window_state,
                                                 panel_size_from_window_state, parse_rviz_config,
                                                 read_rviz_config)

W, H = 1280, 720


def rviz_file(view: str, fixed_frame: str = 'map', state: str = '') -> str:
    """Return an .rviz document with ``view`` (YAML lines) as the current view."""
    geometry_block = f'Window Geometry:\n  QMainWindow State: {state}\n' if state else ''
    return (f'Visualization Manager:\n  Global Options:\n    Fixed Frame: {fixed_frame}\n'
            f'  Views:\n    Current:\n{textwrap.indent(textwrap.dedent(view), " " * 6)}'
            f'    Saved: ~\n{geometry_block}')


def ogre_set_direction(direction, yaw_axis):
    """Ogre SceneNode::setDirection with a fixed yaw axis: the camera's axes (x, y, z)."""
    z = -np.asarray(direction, dtype=float)
    z /= np.linalg.norm(z)
    x = np.cross(yaw_axis, z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def optical_rotation(view):
    return geometry.quaternion_to_matrix(view.optical_pose()[1])


def test_orbit_view_is_the_orbit_around_the_focal_point():
    view = parse_rviz_config(rviz_file("""\
        Class: rviz_default_plugins/Orbit
        Distance: 10
        Focal Point: {X: 1, Y: 2, Z: 0.5}
        Pitch: 0.5
        Yaw: 2.0
        Target Frame: <Fixed Frame>
        """))
    assert view.projection == 'perspective' and view.fixed_frame == 'map'
    offset = view.eye - [1.0, 2.0, 0.5]
    assert np.linalg.norm(offset) == pytest.approx(10.0)
    assert math.asin(offset[2] / 10.0) == pytest.approx(0.5)      # pitch: elevation
    assert math.atan2(offset[1], offset[0]) == pytest.approx(2.0)  # yaw about z
    # The same orientation as Ogre's setDirection with the fixed yaw axis z.
    ogre = ogre_set_direction(view.focus - view.eye, [0, 0, 1])
    expected = optical_pose_from_ogre(view.eye, geometry.matrix_to_quaternion(ogre))[1]
    np.testing.assert_allclose(optical_rotation(view),
                               geometry.quaternion_to_matrix(expected), atol=1e-12)


def test_orbit_defaults_clamps_and_invert_z():
    # Absent properties keep RViz's defaults: Distance 10, Yaw = Pitch = pi/4, focus 0.
    view = parse_rviz_config(rviz_file('Class: rviz_default_plugins/Orbit\n'))
    np.testing.assert_allclose(view.eye, [5.0, 5.0, 10 * math.sin(math.pi / 4)])
    steep = parse_rviz_config(rviz_file('Class: rviz_default_plugins/Orbit\nPitch: 3\n'))
    assert steep.eye[2] == pytest.approx(10 * math.sin(math.pi / 2 - 0.001))
    inverted = parse_rviz_config(rviz_file(
        'Class: rviz_default_plugins/Orbit\nInvert Z Axis: true\nYaw: 0.3\nPitch: 0.4\n'))
    assert inverted.eye[2] < 0                     # pitch changes sign: below the focus
    np.testing.assert_allclose(inverted.up, [0, 0, -1])
    assert optical_rotation(inverted)[2, 1] > 0    # image "down" (y) points up in the world


@pytest.mark.parametrize('controller', ['XYOrbit', 'ThirdPersonFollower'])
def test_xy_orbit_lifts_the_eye_so_the_focal_point_sits_below_the_centre(controller):
    view = parse_rviz_config(rviz_file(f"""\
        Class: rviz_default_plugins/{controller}
        Distance: 8
        Focal Point: {{X: 3, Y: -1, Z: 0}}
        Pitch: 0.6
        Yaw: 1.0
        Target Frame: <Fixed Frame>
        """))
    camera = RvizCamera.from_look_at(view.eye, view.focus, view.up, (W, H))
    (u, v), = camera.project([[3.0, -1.0, 0.0]])[0]
    focal_px = camera.intrinsic[1, 1]
    # Eye 0.2 d above the orbit eye along the camera's up, same direction: F is at
    # 0.2 d below the axis at depth d, i.e. 0.2 f px below the centre.
    assert u == pytest.approx(W / 2)
    assert v == pytest.approx(H / 2 + 0.2 * focal_px)
    orbit = parse_rviz_config(rviz_file(
        'Class: rviz_default_plugins/Orbit\nDistance: 8\nFocal Point: {X: 3, Y: -1, Z: 0}\n'
        'Pitch: 0.6\nYaw: 1.0\n'))
    np.testing.assert_allclose(optical_rotation(view), optical_rotation(orbit), atol=1e-12)
    assert np.linalg.norm(view.eye - orbit.eye) == pytest.approx(0.2 * 8)


def test_fps_view_matches_rvizs_yaw_pitch_robot_to_camera_rotation():
    view = parse_rviz_config(rviz_file("""\
        Class: rviz_default_plugins/FPS
        Position: {X: 1, Y: 2, Z: 3}
        Pitch: 0.3
        Yaw: 1.2
        Target Frame: <Fixed Frame>
        """))
    np.testing.assert_allclose(view.eye, [1, 2, 3])
    forward = view.focus - view.eye
    np.testing.assert_allclose(forward, [math.cos(1.2) * math.cos(0.3),
                                         math.sin(1.2) * math.cos(0.3), -math.sin(0.3)])
    # Independent: Ogre quaternion Rz(yaw) Ry(pitch) Ry(-pi/2) Rz(-pi/2), as a matrix product.

    def rot(axis, angle):
        c, s = math.cos(angle), math.sin(angle)
        return {'y': np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
                'z': np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])}[axis]
    ogre = rot('z', 1.2) @ rot('y', 0.3) @ rot('y', -math.pi / 2) @ rot('z', -math.pi / 2)
    expected = optical_pose_from_ogre(view.eye, geometry.matrix_to_quaternion(ogre))[1]
    np.testing.assert_allclose(optical_rotation(view),
                               geometry.quaternion_to_matrix(expected), atol=1e-12)


def test_top_down_ortho_view_is_orthographic_from_500_m():
    view = parse_rviz_config(rviz_file("""\
        Angle: 0.5
        Class: rviz_default_plugins/TopDownOrtho
        Scale: 37.5
        Target Frame: <Fixed Frame>
        X: 4
        Y: -3
        """))
    assert view.projection == 'orthographic' and view.ortho_scale == 37.5
    np.testing.assert_allclose(view.eye, [4, -3, 500])
    np.testing.assert_allclose(view.up, [-math.sin(0.5), math.cos(0.5), 0], atol=1e-12)
    camera = OrthographicCamera(view.ortho_scale, (W, H)).with_pose(*view.optical_pose())
    (u, v), = camera.project([[4 + math.cos(0.5), -3 + math.sin(0.5), 0.0]])[0]
    assert (u, v) == pytest.approx((W / 2 + 37.5, H / 2))   # 1 m along the camera's right


def test_animated_port_view_uses_its_fixed_eye_focus_up():
    view = parse_rviz_config(rviz_file("""\
        Class: Animated (rviz_plugin_view_animated)
        Eye (Fixed): {X: 0, Y: -8, Z: 12}
        Focus (Fixed): {X: 1, Y: 2, Z: 0}
        Up Axis (Fixed): {X: 0, Y: 0, Z: 1}
        Mode: ORBIT
        """))
    np.testing.assert_allclose(view.eye, [0, -8, 12])
    np.testing.assert_allclose(view.focus, [1, 2, 0])


def test_leading_slash_fixed_frame_and_named_target_frame():
    view = parse_rviz_config(rviz_file(
        'Class: rviz_default_plugins/Orbit\nTarget Frame: odom\n', fixed_frame='/odom'))
    assert view.fixed_frame == 'odom'


@pytest.mark.parametrize('text, message', [
    (rviz_file('Class: rviz_default_plugins/Orbit\nTarget Frame: base_link\n'),
     "Target Frame 'base_link' is not the fixed frame 'map'"),
    (rviz_file('Class: rviz/XYOrbit\n'), "unknown view controller class 'rviz/XYOrbit'.*ROS 1"),
    (rviz_file('Class: my_pkg/Fancy\n'), "unknown view controller class 'my_pkg/Fancy'"),
    (rviz_file('Class: rviz_default_plugins/Orbit\nDistance: far\n'),
     'Distance must be a finite number'),
    (rviz_file('Class: rviz_default_plugins/Orbit\nFocal Point: 3\n'), 'Focal Point must hold'),
    (rviz_file('Class: rviz_default_plugins/TopDownOrtho\nScale: 0\n'),
     'Scale must be a positive number'),
    ('Visualization Manager: [1, 2\n', 'not a valid .rviz'),
    ('Panels: []\n', "no 'Visualization Manager:'"),
    ('Visualization Manager:\n  Displays: []\n', "no 'Views:'"),
    ('42\n', 'not a mapping'),
])
def test_bad_files_are_refused_with_a_reason(text, message):
    with pytest.raises(ValueError, match=message):
        parse_rviz_config(text, 'test.rviz')


def test_missing_file_is_a_value_error(tmp_path):
    with pytest.raises(ValueError, match='cannot read rviz_config'):
        read_rviz_config(tmp_path / 'nope.rviz')


def test_window_state_round_trip_gives_the_panel_size():
    state = encode_window_state({0: [('Displays', 500), ('Selection', 200)], 1: [('Views', 700)],
                                 3: [('Time', 1900)]}, (1111, 555), {0: 300, 1: 250, 3: 60})
    decoded = decode_window_state(state)
    assert decoded.central_size == (1111 + 32, 555)
    assert decoded.panel_size == (1111, 555)
    assert decoded.docks[0] == (300, 555) and decoded.docks[1] == (250, 555)
    view = parse_rviz_config(rviz_file('Class: rviz_default_plugins/Orbit\n', state=state))
    assert view.panel_size == (1111, 555)


@pytest.mark.parametrize('state', ['zz', '000000ff', '000000ff00000000fd00000009',
                                   '000000fe00000000fd00000000000005200000002d'])
def test_undecodable_window_state_gives_no_panel_size(state):
    assert panel_size_from_window_state(state) is None
    view = parse_rviz_config(rviz_file('Class: rviz_default_plugins/Orbit\n', state=state))
    assert view.panel_size is None
