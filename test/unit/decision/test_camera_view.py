"""Regions are used only when made for the camera view on camera/pose (decision.camera_view)."""

import numpy as np

from eye_bci_ros2.decision.camera_view import ViewGate

KITCHEN = np.array([0.0, -4.0, 3.0, 0.1, 0.2, 0.3, 0.9])
OVERVIEW = np.array([0.0, -8.0, 12.0, 0.0, 0.0, 0.0, 1.0])


def test_regions_of_the_view_shown_are_used_others_never():
    gate = ViewGate(hold_s=1.0)
    gate.camera(KITCHEN)
    assert gate.offer(KITCHEN.copy(), 'kitchen regions', 0.0)
    assert not gate.offer(OVERVIEW, 'overview regions', 0.1)
    assert gate.expired(1.0) == []                      # not yet: its pose may be coming
    assert [list(view) for view in gate.expired(1.2)] == [list(OVERVIEW)]
    assert gate.ignored == 1
    assert gate.camera(OVERVIEW) is None                # dropped, not used later


def test_regions_that_arrive_before_their_pose_are_used_when_it_comes():
    gate = ViewGate()
    assert not gate.offer(KITCHEN, 'first', 0.0)         # no view known yet
    assert not gate.offer(KITCHEN, 'second', 0.1)
    assert gate.camera(KITCHEN) == 'second'              # the newest made for it
    assert gate.camera(KITCHEN) is None and gate.expired(5.0) == []


def test_regions_that_do_not_say_their_view_are_used_as_before():
    assert ViewGate().offer(None, 'drawn by hand', 0.0)


def test_a_refused_pose_or_a_fast_camera_keeps_the_regions_of_the_views_shown():
    gate = ViewGate()
    gate.camera(KITCHEN)
    gate.camera(np.full(7, np.nan))                     # the projector refuses it
    moved = KITCHEN + 0.01
    gate.camera(moved)
    assert gate.offer(KITCHEN, 'one pose behind', 0.0) and gate.offer(moved, 'now', 0.0)
