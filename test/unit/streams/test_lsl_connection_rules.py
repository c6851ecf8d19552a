"""
The LSL connection's pure rules: the stamp mapping, gaps, and which streams a profile selects.

No liblsl here: these functions take numbers and descriptions.  The
connection that uses them runs on real liblsl, real outlets on loopback, in
``test/streams/test_lsl_connection.py``.
"""

import numpy as np
import pytest

from eye_bci_ros2.gaze.profiles import build_config, PROFILES
from eye_bci_ros2.gaze.stream import misfit
from eye_bci_ros2.ssvep.eeg_stream import EegStreamProfile
from eye_bci_ros2.streams.lsl_connection import (acquisition_stamps_ns, find_gaps,
                                                 StreamDescription)


def stream(uid, stream_type='Gaze', name='tracker', source_id='', channels=2, rate=0.0,
           created_at=1.0, labels=('', '')):
    """Describe a stream as the network advertises it."""
    return StreamDescription(uid=uid, name=name, stream_type=stream_type, source_id=source_id,
                             hostname='host', channel_count=channels, nominal_srate=rate,
                             created_at=created_at, labels=tuple(labels))


def test_stamps_map_by_the_clock_offset():
    # LSL clock 1000 s here, ROS clock 5000 s: a sample taken at sender time 900 s with an
    # offset of +99.5 s was taken at 999.5 s here, 0.5 s ago: ROS 4999.5 s.
    stamps_ns, good = acquisition_stamps_ns(np.array([899.9, 900.0]), 99.5,
                                            5_000_000_000_000, 1000.0)
    np.testing.assert_array_equal(stamps_ns, [4_999_400_000_000, 4_999_500_000_000])
    assert good.all()


def test_without_an_offset_the_newest_sample_is_placed_now_keeping_the_spacing():
    stamps_ns, good = acquisition_stamps_ns(np.array([10.0, 10.25, 10.5]), None,
                                            5_000_000_000_000, 1000.0)
    np.testing.assert_array_equal(stamps_ns,
                                  [4_999_500_000_000, 4_999_750_000_000, 5_000_000_000_000])
    assert good.all()


def test_corrupt_stamps_are_marked_not_good():
    stamps_ns, good = acquisition_stamps_ns(np.array([1.0, np.nan, 1e12, -1e12]), 0.0,
                                            10_000_000_000, 2.0)
    assert good.tolist() == [True, False, False, False]
    assert stamps_ns.tolist() == [9_000_000_000, 0, 0, 0]


def test_gaps_are_found_in_regular_streams_only():
    rate = 250.0
    times = np.arange(1000) / rate
    times[500:] += 0.3   # 0.3 s missing
    assert np.allclose(find_gaps(times, rate), [0.3 + 1 / rate])
    assert len(find_gaps(times + 1e-4 * np.sin(times), rate)) == 1   # jitter is not a gap
    assert len(find_gaps(times, 0.0)) == 0   # irregular streams have no gaps
    # A gap between two chunks: the previous chunk's last stamp counts.
    assert np.allclose(find_gaps(times[500:600], rate, previous=times[499]), [0.3 + 1 / rate])
    assert len(find_gaps(times[100:200], rate, previous=times[99])) == 0


def test_eeg_profile_selects_by_layout_type_name_and_source():
    profile = EegStreamProfile({'layout': 'liveamp', 'stream_type': '', 'stream_name': '',
                                'source_id': 'amp-7'})
    assert profile.predicate() == "type='EEG' and source_id='amp-7'"
    assert profile.matches(stream('x', stream_type='EEG', name='LiveAmpSN-1234',
                                  source_id='amp-7'))
    assert not profile.matches(stream('x', stream_type='EEG', name='obci_eeg1',
                                      source_id='amp-7'))
    assert not profile.matches(stream('x', stream_type='EEG', name='LiveAmpSN-1234',
                                      source_id='amp-8'))


@pytest.mark.parametrize('sender', ['tobii_pro', 'pupil_capture', 'xy_pixels'])
def test_each_application_layout_fits_its_profile_and_is_named_under_another(sender):
    """Every tracker layout is taken by its own profile and refused, naming it, by the others."""
    spec = PROFILES[sender]
    labels = spec.channel_labels if spec.labelled else ('',) * len(spec.channel_labels)
    for profile_name in ('tobii_pro', 'pupil_capture', 'xy_pixels'):
        reason = misfit(build_config({'profile': profile_name}), labels, len(labels))
        if profile_name == sender:
            assert reason is None
        elif len(PROFILES[profile_name].channel_labels) != len(labels):
            assert f"does not fit profile '{profile_name}'" in reason
            assert f'profile:={sender}' in reason
