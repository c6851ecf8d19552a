"""
Camera faults: degenerate views, broken poses, no pose at all, a camera inside a marker.

Driven through the real camera_tracker, marker_projector and choice_arbiter
(:class:`fault_rig.Pipeline`).  After each fault: the nodes answer, the last
good camera (and so the regions) is kept, the log says what was wrong, and a
round still chooses exactly what the gaze looks at.
"""

import math

from fault_rig import (cube, EYE, FOCUS, LogTap, Pipeline, room_markers, SELF_CLOSED_ROUNDS,
                       static_camera, UP, WAIT_S)
import numpy as np
import pytest
from visualization_msgs.msg import MarkerArray

from eye_bci_ros2.projection.camera_model import look_at_pose, ogre_pose_from_optical
from eye_bci_ros2.ros.conversions import pose_to_arrays, stamp_to_ns

pytestmark = pytest.mark.ros

NAN, INF = math.nan, math.inf
VIEW = np.subtract(FOCUS, EYE)

#: A second good view (RViz moved a little), as the Ogre pose RViz publishes.
LIVE_EYE = [1.0, -9.0, 11.0]
LIVE_OGRE = ogre_pose_from_optical(*look_at_pose(LIVE_EYE, FOCUS, UP))


def same_regions(first, second, atol=1e-6):
    """Assert two {label: polygon} region sets are the same."""
    assert sorted(first) == sorted(second)
    for label in first:
        np.testing.assert_allclose(first[label], second[label], atol=atol)


def expected_regions(camera, markers):
    """{label: polygon} that ``camera`` should give ``markers`` (visible ones only)."""
    positions = np.array([pose_to_arrays(m.pose)[0] for m in markers])
    quaternions = np.array([pose_to_arrays(m.pose)[1] for m in markers])
    scales = np.array([[m.scale.x, m.scale.y, m.scale.z] for m in markers])
    polygons, visible = camera.box_regions(positions, quaternions, scales)
    return {m.text: polygons[i] for i, m in enumerate(markers) if visible[i]}


def distinct(polygon):
    """Sorted distinct vertices of a region, for comparing padded outlines."""
    return np.unique(np.round(polygon, 6), axis=0)


# -- static view parameters ------------------------------------------------------------------

VIEW_FAULTS = {
    'static view: eye == focus': ({'eye': list(FOCUS)}, 'equals focus'),
    'static view: focus == eye': ({'focus': list(EYE)}, 'equals focus'),
    'static view: up parallel to the view': ({'up': (VIEW / 7.0).tolist()}, 'parallel'),
    'static view: up opposite to the view': ({'up': (-VIEW).tolist()}, 'parallel'),
    'static view: zero up vector': ({'up': [0.0, 0.0, 0.0]}, 'zero'),
    'static view: NaN eye': ({'eye': [0.0, NAN, 12.0]}, 'NaN'),
}


@pytest.mark.parametrize('name', sorted(VIEW_FAULTS))
def test_degenerate_static_view_is_rejected_and_the_regions_kept(graph, capfd, fault, name):
    values, reason = VIEW_FAULTS[name]
    rig = Pipeline(graph, arbiter_parameters=SELF_CLOSED_ROUNDS)
    log = LogTap(capfd)
    before = rig.offer_rooms()
    poses = len(rig.poses.messages)
    key = next(iter(values))
    old = graph.get_parameters('/camera_tracker', [key])
    with fault('camera', name):
        mark = log.mark()
        result, = graph.set_parameters('/camera_tracker', values)
        assert not result.successful and reason in result.reason, result.reason
        assert log.wait_for(graph, f'camera_tracker.*rejected.*{reason}', mark)
        assert graph.get_parameters('/camera_tracker', [key]) == old
        graph.spin_for(0.3)
        assert len(rig.poses.messages) == poses, 'a pose was published for a rejected view'
        same_regions(rig.current(), before)
        rig.choose('bedroom')


# -- RViz poses ------------------------------------------------------------------------------

RVIZ_POSE_FAULTS = {
    'RViz pose: NaN position': (([NAN, -9.0, 11.0], LIVE_OGRE[1]), 'NaN'),
    'RViz pose: infinite position': (([1.0, INF, 11.0], LIVE_OGRE[1]), 'NaN or infinite'),
    'RViz pose: NaN orientation': ((LIVE_OGRE[0], [NAN, 0.0, 0.0, 1.0]), 'NaN'),
    'RViz pose: zero quaternion': ((LIVE_OGRE[0], [0.0, 0.0, 0.0, 0.0]), 'zero length'),
}


@pytest.mark.parametrize('name', sorted(RVIZ_POSE_FAULTS))
def test_bad_rviz_pose_is_ignored_and_the_last_good_view_kept(graph, capfd, fault, name):
    (position, quaternion), reason = RVIZ_POSE_FAULTS[name]
    rig = Pipeline(graph, arbiter_parameters=SELF_CLOSED_ROUNDS)
    log = LogTap(capfd)
    rig.offer_rooms()
    # A good live pose first: that is the state to keep.
    rig.publish_rviz_pose(*LIVE_OGRE)
    live = expected_regions(static_camera().with_look_at(LIVE_EYE, FOCUS, UP),
                            room_markers())
    assert graph.spin_until(lambda: len(rig.poses.messages) >= 2, WAIT_S)
    assert graph.spin_until(
        lambda: np.allclose(distinct(rig.current().get('kitchen', np.zeros((1, 2)))),
                            distinct(live['kitchen'])), WAIT_S), 'live pose not applied'
    before, poses = rig.current(), len(rig.poses.messages)
    with fault('camera', name):
        mark = log.mark()
        rig.publish_rviz_pose(position, quaternion)
        assert log.wait_for(graph, f'camera_tracker.*ignoring.*{reason}.*keeping the last '
                                   'good pose', mark)
        assert rig.answers('/camera_tracker')
        assert len(rig.poses.messages) == poses
        np.testing.assert_allclose(pose_to_arrays(rig.poses.last.pose)[0], LIVE_EYE)
        same_regions(rig.current(), before)
        rig.choose('kitchen')


def test_non_unit_rviz_quaternion_means_the_same_view(graph, capfd, fault):
    rig = Pipeline(graph, arbiter_parameters=SELF_CLOSED_ROUNDS)
    rig.offer_rooms()
    with fault('camera', 'RViz pose: non-unit quaternion (x1000)'):
        rig.publish_rviz_pose(LIVE_OGRE[0], np.asarray(LIVE_OGRE[1]) * 1000.0)
        assert graph.spin_until(lambda: len(rig.poses.messages) >= 2, WAIT_S)
        position, quaternion = pose_to_arrays(rig.poses.last.pose)
        assert np.linalg.norm(quaternion) == pytest.approx(1.0)
        expected = look_at_pose(LIVE_EYE, FOCUS, UP)
        np.testing.assert_allclose(position, expected[0], atol=1e-9)
        assert abs(np.dot(quaternion, expected[1])) == pytest.approx(1.0, abs=1e-9)
        rig.choose('bathroom')


def test_camera_absurdly_far_away_shows_nothing_then_recovers(graph, capfd, fault):
    rig = Pipeline(graph, arbiter_parameters=SELF_CLOSED_ROUNDS)
    before = rig.offer_rooms()
    with fault('camera', 'RViz pose 1e300 m away'):
        count = len(rig.regions.messages)
        rig.publish_rviz_pose([0.0, -1e300, 1e300], LIVE_OGRE[1])
        assert graph.spin_until(lambda: len(rig.poses.messages) >= 2, WAIT_S)
        # The projector answers every camera pose with regions (maybe none).
        assert graph.spin_until(lambda: len(rig.regions.messages) > count, WAIT_S)
        for message in rig.regions.messages:
            points = np.array([[p.x, p.y] for m in message.markers for p in m.points])
            assert np.all(np.isfinite(points)), 'non-finite region vertices published'
        assert rig.answers('/marker_projector') and rig.answers('/camera_tracker')
        # Gaze where the rooms were: no choice can come from regions that are not shown.
        if not rig.current():
            rig.request()
            kitchen = np.unique(before['kitchen'], axis=0).mean(axis=0)
            rig.gaze_in_round(rig.rng.normal(kitchen, 5.0, (240, 2)))
            rig.close_window()
            assert rig.finish_round().label is None
        # Back to a sane view: everything works again.
        rig.publish_rviz_pose(*LIVE_OGRE)
        assert graph.spin_until(lambda: len(rig.current()) == 3, WAIT_S)
        rig.choose('kitchen')
        assert rig.published_choices() == ['kitchen']


# -- camera/pose straight into the projector -------------------------------------------------

CAMERA_POSE_FAULTS = {
    'camera/pose: NaN position': (([NAN, 0.0, 5.0], [0.0, 0.0, 0.0, 1.0], 'map'), 'NaN'),
    'camera/pose: infinite orientation': (([0.0, 0.0, 5.0], [INF, 0.0, 0.0, 1.0], 'map'),
                                          'NaN or infinite'),
    'camera/pose: zero quaternion': (([0.0, 0.0, 5.0], [0.0, 0.0, 0.0, 0.0], 'map'),
                                     'zero length'),
    'camera/pose: wrong frame': (([0.0, 0.0, 5.0], [0.0, 0.0, 0.0, 1.0], 'odom'),
                                 "frame 'odom'"),
}


@pytest.mark.parametrize('name', sorted(CAMERA_POSE_FAULTS))
def test_bad_camera_pose_keeps_the_last_camera_for_new_markers(graph, capfd, fault, name):
    (position, quaternion, frame), reason = CAMERA_POSE_FAULTS[name]
    rig = Pipeline(graph, tracker=False, arbiter_parameters=SELF_CLOSED_ROUNDS)
    log = LogTap(capfd)
    camera = static_camera()
    rig.publish_camera(*look_at_pose(EYE, FOCUS, UP))
    before = rig.offer_rooms()
    with fault('camera', name):
        mark = log.mark()
        rig.publish_camera(position, quaternion, frame)
        assert log.wait_for(graph, f'marker_projector.*ignoring camera/pose.*{reason}', mark)
        assert rig.answers('/marker_projector')
        same_regions(rig.current(), before)
        # New markers are still projected with the last good camera.
        markers = room_markers() + [cube('hall', (0.0, -3.0, 0.0), marker_id=9)]
        regions = rig.offer(markers)
        expected = expected_regions(camera, markers)
        for label in expected:
            np.testing.assert_allclose(distinct(regions[label]), distinct(expected[label]),
                                       atol=1e-6)
        rig.choose('hall')


# -- no pose at all --------------------------------------------------------------------------


def test_pose_that_never_arrives_uses_the_static_view(graph, capfd, fault):
    with fault('camera', 'RViz pose never arrives (static view used)'):
        rig = Pipeline(graph, arbiter_parameters=SELF_CLOSED_ROUNDS)
        regions = rig.offer_rooms()
        expected = expected_regions(static_camera(), room_markers())
        assert sorted(regions) == sorted(expected)
        for label in expected:
            np.testing.assert_allclose(distinct(regions[label]), distinct(expected[label]),
                                       atol=1e-6)
        assert 'until rviz/current_camera_pose arrives' in LogTap(capfd).read()
        rig.choose('bathroom')


def test_no_camera_pose_means_no_regions_and_no_choice(graph, capfd, fault):
    rig = Pipeline(graph, tracker=False, arbiter_parameters=SELF_CLOSED_ROUNDS)
    log = LogTap(capfd)
    with fault('camera', 'camera/pose never arrives (no tracker)'):
        markers = room_markers()
        rig.choices_pub.publish(MarkerArray(markers=markers))
        assert log.wait_for(graph, 'marker_projector.*no camera/pose yet')
        assert rig.regions.messages == []
        assert rig.arbiter.rounds_started == 0
        # Gaze where a room would be, even with a request: nothing to choose from.
        rig.request()
        camera = static_camera()
        target = np.unique(expected_regions(camera, markers)['kitchen'],
                           axis=0).mean(axis=0)
        rig.gaze_in_round(rig.rng.normal(target, 5.0, (240, 2)))
        rig.close_window()
        assert rig.finish_round().label is None
        assert rig.published_choices() == []
        # The camera arrives late: the latched markers are projected at once.
        camera_at = rig.now()
        rig.publish_camera(*look_at_pose(EYE, FOCUS, UP))
        assert graph.spin_until(lambda: len(rig.current()) == 3, WAIT_S)
        # And only then: the projector publishes in order, so regions made before the
        # camera (late, or not) would have come first, stamped before it.
        stamps = [stamp_to_ns(marker.header.stamp) * 1e-9
                  for message in rig.regions.messages for marker in message.markers]
        assert stamps and min(stamps) >= camera_at, (stamps, camera_at)
        rig.choose('kitchen')


# -- inside a marker -------------------------------------------------------------------------


def test_camera_inside_a_marker_gives_that_marker_no_region(graph, capfd, fault):
    rig = Pipeline(graph, arbiter_parameters=SELF_CLOSED_ROUNDS)
    rig.offer_rooms()
    # A 2 m box in front of the static camera; then RViz moves the camera into it.
    wardrobe = cube('wardrobe', (0.0, -4.0, 3.0), scale=(2.0, 2.0, 2.0), marker_id=7)
    inside = ogre_pose_from_optical(*look_at_pose([0.0, -4.2, 3.2], FOCUS, UP))
    with fault('camera', 'camera inside a marker'):
        rig.offer(room_markers() + [wardrobe])   # seen from outside: it has a region
        rig.publish_rviz_pose(*inside)
        assert graph.spin_until(lambda: sorted(rig.current()) == sorted(
            ['kitchen', 'bedroom', 'bathroom']), WAIT_S), sorted(rig.current())
        assert rig.answers('/marker_projector')
        # Gaze at a corner of the screen, "on" the box around the eye: no choice.
        rig.request()
        rig.gaze_in_round(rig.rng.normal([100.0, 100.0], 5.0, (240, 2)))
        rig.close_window()
        assert rig.finish_round().label is None
        assert 'wardrobe' not in rig.published_choices()
        rig.choose('bedroom')
