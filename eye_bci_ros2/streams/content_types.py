"""
What an LSL stream carries, told by its content type: the one home of "is it gaze, is it EEG".

LSL's type field follows the XDF meta-data specification's content types (any
case): a gaze bridge told to read an EEG amplifier's stream would read volts as
pixels, and an SSVEP decoder told to read an eye tracker's stream would look
for flicker in screen coordinates.  Both refuse such a stream whatever their
parameters, and neither suggests it when it lists the streams it could take.
"""

from typing import Optional

#: Stream types (lower case) an eye tracker's gaze is sent as (XDF's ``Gaze``, and the
#: trackers' own: Tobii Pro ``Eyetracker``, Tobii Stream Engine ``gaze``).
GAZE_TYPES = frozenset(('gaze', 'eyetracker', 'eye-tracker', 'eyetracking', 'eye_tracker'))
#: Stream types (lower case) that are never an eye tracker's gaze.
NOT_GAZE_TYPES = frozenset(('eeg', 'emg', 'ecg', 'nirs', 'mocap', 'audio', 'markers',
                            'videoraw', 'videocompressed'))
#: Stream types (lower case) that are never EEG (EMG, ECG and the like may be an
#: amplifier's extra channels: the user's call).
NOT_EEG_TYPES = GAZE_TYPES | frozenset(('mocap', 'audio', 'markers', 'videoraw',
                                        'videocompressed'))


def is_gaze_type(stream_type: str) -> bool:
    """Tell whether a stream of this type is an eye tracker's gaze."""
    return stream_type.lower() in GAZE_TYPES


def not_gaze(stream_type: str) -> Optional[str]:
    """Say why a stream of this type is no eye tracker's (None: it may be one)."""
    if stream_type.lower() not in NOT_GAZE_TYPES:
        return None
    return (f'it is an {stream_type} stream, not gaze (a gaze bridge cannot use it): '
            "start the eye tracker's LSL sender (sim_gaze to try without one)")


def not_eeg(stream_type: str) -> Optional[str]:
    """Say why a stream of this type is no EEG amplifier's (None: it may be one)."""
    if stream_type.lower() not in NOT_EEG_TYPES:
        return None
    what = " (an eye tracker's gaze)" if is_gaze_type(stream_type) else ''
    article = 'an' if stream_type[:1].lower() in 'aeiou' else 'a'
    return (f'it is {article} {stream_type} stream{what}, not EEG (an SSVEP decoder cannot use '
            "it): start the amplifier's LSL application (sim_eeg to try without one)")
