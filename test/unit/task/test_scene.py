"""Scene files: the default scene's layout on screen, and clear errors for bad files."""

import os
import re

import numpy as np
from paths import CONFIG
import pytest
import yaml

from eye_bci_ros2.projection import geometry
from eye_bci_ros2.ros.package_files import default_scene_path
from eye_bci_ros2.task.scene import load_scene, parse_scene

#: The set-up the default scene is laid out for: 1280x720 render panel,
#: vertical FOV 45 deg, at (X0, Y0) = (320, 180) on a 1920x1080 screen.
WIDTH, HEIGHT, X0, Y0 = 1280, 720, 320, 180
FOCAL = (HEIGHT / 2) / np.tan(np.radians(45.0) / 2)
INTRINSIC = np.array([[FOCAL, 0, WIDTH / 2, 0], [0, FOCAL, HEIGHT / 2, 0], [0, 0, 1, 0]])

with open(CONFIG / 'scene.yaml') as _f:
    DEFAULT_TEXT = _f.read()


def screen_boxes(view, markers):
    """Screen-px bounding boxes (x_min, y_min, x_max, y_max) of markers seen from a view."""
    polygons, visible = geometry.box_silhouettes(
        [m.position for m in markers], [m.orientation for m in markers],
        [m.scale for m in markers], INTRINSIC, view.external())
    assert visible.all()
    polygons = polygons + [X0, Y0]
    return np.concatenate([np.nanmin(polygons, axis=1), np.nanmax(polygons, axis=1)], axis=1)


def check_layout(boxes):
    """Regions of ~100-250 px, inside the render panel, well apart."""
    sizes = boxes[:, 2:] - boxes[:, :2]
    assert np.all(sizes >= 90) and np.all(sizes <= 260), sizes
    assert np.all(boxes[:, :2] >= [X0, Y0]) and np.all(boxes[:, 2:] <= [X0 + WIDTH, Y0 + HEIGHT])
    for i in range(len(boxes)):
        for j in range(i + 1, len(boxes)):
            gap = max(boxes[i, 0] - boxes[j, 2], boxes[j, 0] - boxes[i, 2],
                      boxes[i, 1] - boxes[j, 3], boxes[j, 1] - boxes[i, 3])
            assert gap >= 100, (i, j, gap)


def test_default_scene_loads_with_rooms_and_tables():
    path = default_scene_path()
    assert os.path.samefile(path, CONFIG / 'scene.yaml')
    scene = load_scene(path)
    assert scene.frame_id == 'map'
    assert scene.room_labels == ('kitchen', 'living_room', 'bedroom', 'office')
    for room in scene.rooms:
        assert [t.marker.text for t in room.tables] == [
            f'{room.name}/table_{i}' for i in (1, 2, 3)]
        # Thin cubes: one side much smaller than the other two, which are equal.
        for marker in [room.marker] + [t.marker for t in room.tables]:
            small, middle, large = np.sort(marker.scale)
            assert small < 0.1 * middle and middle == large
            assert np.isclose(np.linalg.norm(marker.orientation), 1.0)
    assert scene.room('kitchen').table('kitchen/table_2').name == 'table_2'
    assert scene.room('garage') is None and scene.room('kitchen').table('office/table_1') is None


def test_default_scene_regions_on_screen():
    scene = load_scene(default_scene_path())
    check_layout(screen_boxes(scene.overview, [room.marker for room in scene.rooms]))
    for room in scene.rooms:
        check_layout(screen_boxes(room.view, [table.marker for table in room.tables]))


def test_sim_rviz_view_starts_at_the_default_overview():
    from eye_bci_ros2.sim import rviz_view as sim_rviz_view
    overview = load_scene(default_scene_path()).overview
    np.testing.assert_array_equal(overview.eye, sim_rviz_view.DEFAULT_EYE)
    np.testing.assert_array_equal(overview.focus, sim_rviz_view.DEFAULT_FOCUS)
    np.testing.assert_array_equal(overview.up, sim_rviz_view.DEFAULT_UP)


def test_optional_fields_take_defaults():
    scene = parse_scene("""
overview: {eye: [0, -5, 10], focus: [0, 0, 0], up: [0, 0, 1]}
rooms:
  - name: hall
    marker: {position: [0, 0, 0.1], scale: [2, 2, 0.05]}
    view: {eye: [0, -3, 4], focus: [0, 0, 0], up: [0, 0, 1]}
    tables:
      - name: t
        marker: {position: [1, 0, 0.8], orientation: [0, 0, 0, 1], scale: [1, 1, 0.05]}
""")
    assert scene.frame_id == 'map'
    marker = scene.rooms[0].marker
    np.testing.assert_array_equal(marker.orientation, [0, 0, 0, 1])
    assert marker.color.shape == (4,) and marker.color[3] == 1.0
    assert scene.rooms[0].area is None
    assert scene.rooms[0].tables[0].marker.text == 'hall/t'


def edited(old, new, count=1):
    """Return the default scene text with ``old`` replaced by ``new``."""
    assert old in DEFAULT_TEXT
    return DEFAULT_TEXT.replace(old, new, count)


def line_of(text, fragment):
    """1-based line of the first occurrence of ``fragment``."""
    return text[:text.index(fragment)].count('\n') + 1


def error_of(text, source='my_scene.yaml'):
    with pytest.raises(ValueError) as info:
        parse_scene(text, source)
    return str(info.value)


def test_malformed_yaml_names_file_and_line():
    text = edited('  focus: [10.0, 6.0, 0.0]', '  focus: [10.0, 6.0, 0.0')
    message = error_of(text)
    assert message.startswith('my_scene.yaml:')
    assert 'malformed YAML' in message
    line = int(re.match(r'my_scene\.yaml:(\d+):', message).group(1))
    assert abs(line - line_of(text, '  focus: [10.0, 6.0, 0.0')) <= 1


def test_missing_key_is_named():
    text = edited("""    view:
      eye: [15.0, 4.0, 6.5]
      focus: [15.0, 9.3, 0.0]
      up: [0.0, 0.0, 1.0]
""", '')
    message = error_of(text)
    assert "rooms[1]: missing key 'view'" in message
    assert message.startswith(f"my_scene.yaml:{line_of(text, '  - name: living_room')}:")


def test_missing_overview_and_rooms():
    document = yaml.safe_load(DEFAULT_TEXT)
    for key in ('overview', 'rooms'):
        broken = {k: v for k, v in document.items() if k != key}
        assert f"missing key '{key}'" in error_of(yaml.safe_dump(broken))


def test_bad_quaternion_is_rejected_with_its_length():
    text = edited('orientation: [0.0, 0.0, 0.258819, 0.965926]',
                  'orientation: [0.0, 0.0, 0.5, 0.5]')
    message = error_of(text)
    assert 'rooms[0].tables[1].marker.orientation' in message
    assert 'length 0.707107, expected 1' in message
    assert message.startswith(f"my_scene.yaml:{line_of(text, '[0.0, 0.0, 0.5, 0.5]')}:")
    assert 'length 0, expected 1' in error_of(
        edited('orientation: [0.0, 0.0, 0.0, 1.0]', 'orientation: [0, 0, 0, 0]'))
    assert 'list of 4 numbers' in error_of(
        edited('orientation: [0.0, 0.0, 0.0, 1.0]', 'orientation: [0, 0, 1]'))


@pytest.mark.parametrize('old, new, expected', [
    ('scale: [3.0, 3.0, 0.05]', 'scale: [3.0, 0.0, 0.05]', 'side lengths must be positive'),
    ('position: [5.0, 9.0, 0.1]', 'position: [5.0, nine, 0.1]', 'list of 3 numbers'),
    ('position: [5.0, 9.0, 0.1]', 'position: [5.0, .nan, 0.1]', 'NaN or infinite'),
    ('position: [5.0, 9.0, 0.1]', 'position: [5.0, yes, 0.1]', 'list of 3 numbers'),
    ('color: [0.95, 0.55, 0.1, 0.8]', 'color: [242, 140, 25, 200]', 'must be in [0, 1]'),
    ('name: table_3', 'name: table_1', "duplicate name 'table_1'"),
    ('name: office', 'name: kitchen', "duplicate name 'kitchen'"),
    ('name: office', 'name: office/2', "must not contain '/'"),
    ('eye: [5.0, 4.0, 6.5]', 'eye: [5.0, 9.3, 0.0]', 'equals focus'),
    ('eye: [5.0, 4.0, 6.5]', 'eye: [5.0, 9.3, 6.5]', 'parallel to the view'),
    ('area: [0.0, 6.0, 10.0, 12.0]', 'area: [10.0, 6.0, 0.0, 12.0]', 'x_min, y_min'),
    ('    tables:\n      - name: table_1', '    tabels:\n      - name: table_1',
     "unknown key 'tabels'"),
    ('frame_id: map', 'frame_id: map\nframe_id: odom', "duplicate key 'frame_id'"),
    ('frame_id: map', 'frame_id: 7', 'expected a frame name'),
    ('{center: [3.5, 6.0], width: 0.9}', '{center: [3.5, 6.5], width: 0.9}',
     'does not lie within one wall'),
    ('{center: [3.5, 6.0], width: 0.9}', '{center: [0.2, 6.0], width: 0.9}',
     'does not lie within one wall'),
    ('{center: [3.5, 6.0], width: 0.9}', '{center: [3.5, 6.0], width: -1}',
     'expected a width > 0 m'),
    ('- [0.0, 0.0, 20.0, 0.0]  # outer walls', '- [0.0, 0.0, 0.0, 0.0]',
     'a wall shorter than its thickness'),
    ('  wall_thickness: 0.1', '  wall_thickness: 0', 'expected a thickness in (0, 10) m'),
    ('  wall_thickness: 0.1', '  wall_thickness: 0.1\n  window: 1', "unknown key 'window'"),
])
def test_invalid_values_are_explained(old, new, expected):
    assert expected in error_of(edited(old, new))


@pytest.mark.parametrize('text, expected', [
    ('', 'the file is empty'),
    ('- kitchen\n- office\n', 'expected a mapping, got a list'),
    ('overview: {eye: [0, -5, 10], focus: [0, 0, 0], up: [0, 0, 1]}\nrooms: []\n',
     'non-empty list of rooms'),
])
def test_structural_errors(text, expected):
    assert expected in error_of(text)


def test_floor_plan_errors_name_the_line_and_key():
    text = edited('{center: [14.0, 6.0], width: 0.9}', '{center: [14.0, 6.0], width: x}')
    message = error_of(text)
    assert message.startswith(f"my_scene.yaml:{line_of(text, 'width: x')}: "
                              'floor_plan.doors[1].width')


def test_the_default_floor_plan_has_a_door_between_neighbouring_rooms():
    plan = load_scene(CONFIG / 'scene.yaml').floor_plan
    assert plan.wall_thickness == 0.1 and len(plan.walls) == 6
    assert sorted(tuple(d.center) for d in plan.doors) == [
        (3.5, 6.0), (10.0, 5.0), (10.0, 11.0), (14.0, 6.0)]


def test_load_scene_reports_the_file(tmp_path):
    path = tmp_path / 'broken.yaml'
    path.write_text(edited('scale: [3.0, 3.0, 0.05]', 'scale: [3.0, 3.0]'))
    with pytest.raises(ValueError, match=re.escape(str(path)) + r':\d+: rooms\[0\]\.marker'):
        load_scene(path)
    with pytest.raises(ValueError, match='cannot read scene file .*missing.yaml'):
        load_scene(tmp_path / 'missing.yaml')
