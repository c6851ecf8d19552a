"""Pure tests of the gaze profiles: configuration, channel mapping, conversion (no ROS, no LSL)."""

from lsl_outlets import sample_for
import numpy as np
import pytest

from eye_bci_ros2.gaze.profiles import (build_config, convert, PROFILE_NAMES, PROFILES,
                                        resolve_mapping, stream_matches, xpath_predicate)

NAN = float('nan')


def mapping_for(profile, labels=None, channel_count=None, **params):
    """Map ``profile`` (plus parameters) onto a stream laid out as its app lays it out."""
    config = build_config({'profile': profile, **params})
    spec = PROFILES[profile]
    if labels is None:
        labels = list(spec.channel_labels) if spec.labelled else []
    if channel_count is None:
        channel_count = len(spec.channel_labels)
    return resolve_mapping(config, labels, channel_count)


def test_xy_pixels_scales_the_1366x768_screen_to_1920x1080():
    mapping = mapping_for('xy_pixels')
    batch = convert(np.array([[0, 0], [683, 384], [1366, 768], [100, 700]], np.float32),
                    mapping)
    # 100 * 1920 / 1366 = 140.556..., 700 * 1080 / 768 = 984.375
    np.testing.assert_allclose(
        batch.xy, [[0, 0], [960, 540], [1920, 1080], [140.5563689604685, 984.375]],
        rtol=0, atol=1e-9)
    assert batch.keep.all()
    assert batch.dropped == {'nonfinite': 0, 'low_confidence': 0, 'offscreen': 0}


def test_tobii_pro_averages_valid_eyes_and_drops_when_both_are_lost():
    mapping = mapping_for('tobii_pro')
    #                  left_x left_y pupil right_x right_y pupil
    samples = np.array([[0.25, 0.5, 3.0, 0.35, 0.5, 3.0],    # both -> mean (0.3, 0.5)
                        [NAN, NAN, NAN, 0.5, 0.25, 3.0],     # left lost -> right
                        [0.1, 0.9, 3.0, NAN, NAN, NAN],      # right lost -> left
                        [0.2, NAN, 3.0, 0.75, 0.5, 3.0],     # left half-lost -> right
                        [NAN, NAN, NAN, NAN, NAN, NAN]])     # both lost -> dropped
    batch = convert(samples, mapping)
    np.testing.assert_allclose(batch.xy, [[576, 540], [960, 270], [192, 972], [1440, 540]],
                               atol=1e-9)
    assert batch.keep.tolist() == [True, True, True, True, False]
    assert batch.dropped['nonfinite'] == 1


def test_pupil_capture_flips_bottom_left_origin_and_drops_low_confidence():
    mapping = mapping_for('pupil_capture')
    labels = PROFILES['pupil_capture'].channel_labels
    rows = np.full((4, len(labels)), NAN)
    conf, nx, ny = (labels.index(name) for name in ('confidence', 'norm_pos_x', 'norm_pos_y'))
    rows[:, [conf, nx, ny]] = [[0.9, 0.25, 0.75],   # -> (480, (1 - 0.75) * 1080 = 270)
                               [0.6, 0.0, 0.0],     # at the threshold, bottom-left corner
                               [0.59, 0.5, 0.5],    # below 0.6
                               [NAN, 0.5, 0.5]]     # unknown confidence
    batch = convert(rows, mapping)
    np.testing.assert_allclose(batch.xy, [[480, 270], [0, 1080]], atol=1e-9)
    assert batch.dropped == {'nonfinite': 0, 'low_confidence': 2, 'offscreen': 0}


def test_tobii_stream_engine_unlabelled_normalised_top_left():
    mapping = mapping_for('tobii_stream_engine')
    batch = convert(np.array([[0.5, 0.5], [1.0, 0.0], [0.1, 0.2]]), mapping)
    np.testing.assert_allclose(batch.xy, [[960, 540], [1920, 0], [192, 216]], atol=1e-9)


def test_custom_pixels_bottom_left_with_labels():
    mapping = mapping_for('custom', labels=['t', 'gx', 'gy'], channel_count=3,
                          x_channel='gx', y_channel='gy', units='pixels',
                          origin='bottom_left', source_width=800, source_height=600,
                          screen_width=1600, screen_height=1200)
    batch = convert(np.array([[7.0, 400.0, 150.0], [7.0, 0.0, 600.0]]), mapping)
    # x 400 * 2 = 800; y (600 - 150) * 2 = 900.
    np.testing.assert_allclose(batch.xy, [[800, 900], [0, 0]], atol=1e-9)


def test_offscreen_margin_is_inclusive_and_nonfinite_values_are_dropped():
    mapping = mapping_for('custom', offscreen_margin_px=100.0)
    samples = np.array([[-100.0, 540.0],    # exactly at the margin: kept
                        [-100.5, 540.0],    # beyond it
                        [960.0, 1180.0],    # kept
                        [960.0, 1180.01],   # beyond
                        [np.inf, 10.0],
                        [10.0, -np.inf],
                        [1e308, 1e308]])    # finite, but not a screen point
    batch = convert(samples, mapping)
    assert batch.keep.tolist() == [True, False, True, False, False, False, False]
    np.testing.assert_allclose(batch.xy, [[-100, 540], [960, 1180]])
    assert batch.dropped == {'nonfinite': 2, 'low_confidence': 0, 'offscreen': 3}


def test_wrong_sample_width_is_rejected():
    with pytest.raises(ValueError, match=r'shape \(N, 2\)'):
        convert(np.zeros((3, 4)), mapping_for('xy_pixels'))


def test_profile_defaults_and_explicit_parameters_precedence():
    config = build_config({'profile': 'pupil_capture'})
    assert (config.stream_type, config.stream_name, config.source_id) == \
        ('Gaze', 'pupil_capture', '')
    assert config.x_channels == ('norm_pos_x',) and config.confidence_channel == 'confidence'
    assert config.min_confidence == 0.6 and config.origin == 'bottom_left'

    config = build_config({'profile': 'pupil_capture', 'stream_name': '*', 'origin': 'top_left',
                           'confidence_channel': 'none', 'min_confidence': 0.2,
                           'source_id': 'abc'})
    assert config.stream_name == '' and config.source_id == 'abc'
    assert config.origin == 'top_left' and config.confidence_channel is None
    assert config.min_confidence == 0.2

    xy = build_config({'profile': 'xy_pixels', 'screen_width': 1280})
    assert (xy.source_width, xy.source_height, xy.screen_width) == (1366, 768, 1280)
    assert build_config({'profile': 'xy_pixels', 'source_width': 1600}).source_width == 1600
    custom = build_config({'profile': 'custom', 'screen_width': 800, 'screen_height': 600})
    assert (custom.source_width, custom.source_height) == (800, 600)
    assert build_config({'profile': 'tobii_pro'}).x_channels == ('left_x', 'right_x')
    assert build_config({'x_channel': '2, 4', 'y_channel': 'a,b'}).x_channels == (2, 4)


@pytest.mark.parametrize('values, message', [
    ({'profile': 'eyelink'}, "unknown profile 'eyelink'"),
    ({'x_channel': 'left_x,right_x'}, 'x_channel lists 2'),
    ({'x_channel': 'a,,b', 'y_channel': 'c,d,e'}, 'x_channel'),
    ({'units': 'inches'}, "units 'inches'"),
    ({'origin': 'centre'}, "origin 'centre'"),
    ({'screen_width': 0}, 'screen size must be positive'),
    ({'confidence_channel': 'a,b'}, 'must name one channel'),
    ({'profile': 'custom', 'x_channel': '0', 'y_channel': '0'},
     "x_channel and y_channel both name channel '0': x and y must be two different channels"),
    ({'x_channel': 'lx,rx', 'y_channel': 'ly,lx'}, "both name channel 'lx'"),
])
def test_bad_configuration_says_why(values, message):
    with pytest.raises(ValueError, match=message):
        build_config(values)


def test_mapping_by_label_index_and_fallback_layout():
    # Labels are found wherever the channels are.
    mapping = mapping_for('tobii_pro', labels=['right_x', 'right_y', 'left_x', 'left_y'],
                          channel_count=4)
    assert mapping.x_index.tolist() == [2, 0] and mapping.y_index.tolist() == [3, 1]
    # An unlabelled stream with exactly the app's layout uses the app's order.
    assert mapping_for('tobii_pro', labels=[]).x_index.tolist() == [0, 3]
    with pytest.raises(ValueError, match="no channel labelled 'left_x'"):
        mapping_for('tobii_pro', labels=[], channel_count=4)
    with pytest.raises(ValueError, match=r"labelled 'norm_pos_x' \(its 2 channel labels: a, b"):
        mapping_for('pupil_capture', labels=['a', 'b'], channel_count=2)
    with pytest.raises(ValueError, match='index 1 is out of range, the stream has 1 channel'):
        mapping_for('xy_pixels', channel_count=1)
    # A label and an index naming one column: refused once bound to the stream.
    config = build_config({'profile': 'custom', 'x_channel': 'gx', 'y_channel': '0'})
    with pytest.raises(ValueError, match='x_channel and y_channel both name column 0: x and y'):
        resolve_mapping(config, ['gx', 'gy'], 2)


def test_stream_selection_and_resolver_predicate():
    config = build_config({'profile': 'tobii_pro', 'source_id': 'id1'})
    assert stream_matches(config, 'Eyetracker', 'Tobii', 'id1')
    assert not stream_matches(config, 'Eyetracker', 'Tobii', 'id2')
    assert not stream_matches(config, 'Gaze', 'Tobii', 'id1')
    assert xpath_predicate(config) == "type='Eyetracker' and name='Tobii' and source_id='id1'"
    anything = build_config({'profile': 'custom'})
    assert stream_matches(anything, 'x', 'y', 'z') and xpath_predicate(anything) == ''
    quoted = build_config({'profile': 'custom', 'stream_name': "it's", 'source_id': '"a\'b"'})
    assert xpath_predicate(quoted) == 'name="it\'s"'   # unquotable source_id left to Python
    assert stream_matches(quoted, 'any', "it's", '"a\'b"')


@pytest.mark.parametrize('profile', PROFILE_NAMES)
def test_test_outlet_encoding_round_trips(profile):
    """lsl_outlets.sample_for is the inverse of the conversion (others rely on it)."""
    points = np.random.default_rng(7).uniform([0, 0], [1920, 1080], size=(50, 2))
    samples = sample_for(profile, points, confidence=0.95, eye_offset_px=(12.0, -7.0))
    batch = convert(samples, mapping_for(profile))
    np.testing.assert_allclose(batch.xy, points, atol=1e-6)
    lost = sample_for(profile, points, lost_eye='both')
    assert not convert(lost, mapping_for(profile)).keep.any()
