"""gaze/samples and gaze/point serialized without rclpy's Python message: the same messages."""

from geometry_msgs.msg import PointStamped
import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import PointCloud2, PointField

from eye_bci_ros2.ros.conversions import (gaze_batch, gaze_batch_arrays, gaze_cdr, gaze_point,
                                          gaze_point_cdr)

RNG = np.random.default_rng(4)


def batch(count):
    """Stamps (N,) ns, irregular, and points (N, 2) px."""
    stamps = 1_790_000_000_123_456_789 + np.cumsum(RNG.integers(1, 2_000_000, count))
    return stamps, RNG.normal(600.0, 300.0, (count, 2))


@pytest.mark.parametrize('frame', ['screen', '', 'a', 'ab', 'abc', 'camera_frame'])
@pytest.mark.parametrize('count', [1, 2, 3, 24, 1024])
def test_built_bytes_are_the_message_gaze_batch_builds(frame, count):
    stamps, xy = batch(count)
    message = gaze_batch(stamps, xy, frame)
    built = gaze_cdr(frame).build(stamps, xy)
    assert len(built) == len(serialize_message(message))
    assert deserialize_message(built, PointCloud2) == message


@pytest.mark.parametrize('frame', ['screen', ''])
@pytest.mark.parametrize('count', [1, 5, 240])
def test_read_gives_what_gaze_batch_arrays_gives(frame, count):
    stamps, xy = batch(count)
    message = gaze_batch(stamps, xy, frame)
    expected = gaze_batch_arrays(message)
    # Our bytes, and rclpy's (whose padding bytes are left undefined).
    for data in (gaze_cdr(frame).build(stamps, xy), serialize_message(message)):
        got_stamps, got_xy, stamped = gaze_cdr().read(data)
        np.testing.assert_array_equal(got_stamps, expected[0])
        np.testing.assert_array_equal(got_xy, expected[1])
        assert stamped


def test_an_unstamped_batch_is_reported_so():
    message = gaze_batch(np.array([0, 1000]), np.array([[1.0, 2.0], [3.0, 4.0]]))
    stamps, _, stamped = gaze_cdr().read(serialize_message(message))
    assert not stamped
    np.testing.assert_allclose(stamps, [0.0, 1e-6])


def _reason(message):
    with pytest.raises(ValueError) as error:
        gaze_batch_arrays(message)
    return str(error.value)


@pytest.mark.parametrize('spoil', ['frame', 'fields', 'bigendian', 'size', 'point_step'])
def test_other_layouts_are_refused_with_gaze_batch_arrays_reason(spoil):
    message = gaze_batch(*batch(4))
    if spoil == 'frame':
        message.header.frame_id = 'map'
    elif spoil == 'fields':
        message.fields = message.fields[:2] + [
            PointField(name='z', offset=16, datatype=PointField.FLOAT64, count=1)]
    elif spoil == 'bigendian':
        message.is_bigendian = True
    elif spoil == 'size':
        message.data = message.data[:-24]
    else:
        message.point_step = 32
    with pytest.raises(ValueError) as error:
        gaze_cdr().read(serialize_message(message))
    assert str(error.value) == _reason(message)


def test_bytes_that_are_no_message_are_refused():
    with pytest.raises(ValueError, match='not a PointCloud2'):
        gaze_cdr().read(b'\x00\x01\x00\x00\x05')


@pytest.mark.parametrize('frame', ['screen', '', 'a', 'abcd', 'camera_frame'])
@pytest.mark.parametrize('stamp_ns', [0, 1_790_000_000_999_999_999, 5])
def test_a_built_gaze_point_is_the_message_gaze_point_builds(frame, stamp_ns):
    built = gaze_point_cdr(stamp_ns, 1365.25, -0.5, frame)
    message = gaze_point(stamp_ns, 1365.25, -0.5, frame)
    assert len(built) == len(serialize_message(message))
    assert deserialize_message(built, PointStamped) == message
