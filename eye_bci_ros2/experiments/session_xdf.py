"""
A recorded session, read from LabRecorder's XDF (the pipeline's markers and the gaze).

The marker stream of ``session_markers`` (type ``Markers``, name ``eye_bci_markers...``;
one JSON object per event, :mod:`eye_bci_ros2.recordings.session_markers`) gives the
questions with their options' screen regions, the choices, the rounds without a choice,
the menu's answers and outcomes, the robot's goals and progress and the validations; the
gaze stream is read as the bridge reads it (:func:`eye_bci_ros2.recordings.xdf.gaze_from_stream`:
the tracker application's layout, scaled to the person's screen).  Times are s on the
XDF's clock (the recording machine's LSL clock, LabRecorder's offsets applied).

The XDF holds no cue, map, plan or odometry: with the XDF alone the report has no
accuracy and draws each drive without its map.
"""

import json
from pathlib import Path
from typing import Dict, List, Optional, Sequence

import numpy as np

from eye_bci_ros2.decision.regions import RegionSet
from eye_bci_ros2.experiments.session_bag import Session
from eye_bci_ros2.projection.visual_angle import DEFAULT_VIEWING, ScreenGeometry
from eye_bci_ros2.recordings.gaze_recording import RecordingError
from eye_bci_ros2.recordings.session_markers import (
    ANSWER, ARRIVED, CHOICE, DRIVING, FAILED, GO, GOAL, MARKER_TYPE, NO_CHOICE, OUTCOME,
    parse_marker, QUESTION, STATE, STOP, STOPPED, STREAM_PREFIX, VALIDATION)
from eye_bci_ros2.recordings.xdf import gaze_from_stream, load_xdf_streams, pick_gaze_stream

#: Suffixes of an XDF file.
XDF_SUFFIXES = ('.xdf', '.xdfz')


def _first(value) -> str:
    return str(value[0]) if isinstance(value, list) and value else str(value or '')


def marker_streams(streams: Sequence[Dict]) -> List[Dict]:
    """Return the pipeline's marker streams among an XDF file's."""
    return [s for s in streams if _first(s['info'].get('type')) == MARKER_TYPE
            and _first(s['info'].get('name')).startswith(STREAM_PREFIX)]


def _question(session: Session, stamp: float, body: Dict) -> None:
    session.requests.append(stamp)
    options = body.get('options') or []
    if not options:
        return
    outlines = [np.asarray(option['region'], dtype=float).reshape(-1, 2) for option in options]
    width = max(len(outline) for outline in outlines)
    polygons = np.full((len(outlines), max(width, 3), 2), np.nan)
    for row, outline in enumerate(outlines):
        polygons[row, :len(outline)] = outline
        polygons[row, len(outline):] = outline[-1]
    session.regions.append(RegionSet([option['label'] for option in options], polygons, stamp))


def add_events(session: Session, events: Sequence) -> None:
    """Add ``(stamp s, marker body)`` events to ``session`` (module doc)."""
    for stamp, body in events:
        event = body.get('event')
        if event == QUESTION:
            _question(session, stamp, body)
        elif event == CHOICE:
            session.choices.append((stamp, body.get('label')))
        elif event == NO_CHOICE:
            session.no_choices.append((stamp, body.get('reason') or ''))
        elif event in (ANSWER, GO, STOP):
            session.answers.append((stamp, body.get('label')))
        elif event == OUTCOME:
            session.results.append((stamp, body.get('label')))
        elif event in (DRIVING, ARRIVED, STOPPED, FAILED):
            session.progress.append((stamp, body.get('text', event)))
        elif event == STATE:
            session.states.append((stamp, body.get('state', '')))
        elif event == GOAL:
            session.goals.append((stamp, np.array([body['x'], body['y'],
                                                   body.get('yaw_rad') or 0.0])))
        elif event == VALIDATION:
            session.validations.append((stamp, json.dumps(body)))


def read_xdf_session(path, profile: Optional[str] = None,
                     screen: ScreenGeometry = DEFAULT_VIEWING,
                     source_size: Optional[Sequence[int]] = None) -> Session:
    """
    Read a session's XDF file.

    :param profile: the tracker application's layout (default: from the gaze stream).
    :raises ValueError: unreadable, or without the pipeline's marker stream (one line).
    """
    path = Path(path)
    streams = load_xdf_streams(path)     # RecordingError is a ValueError
    found = marker_streams(streams)
    if len(found) != 1:
        names = ', '.join(_first(s['info'].get('name')) for s in streams) or 'none'
        raise ValueError(f'{path}: {len(found)} marker streams of eye_bci_ros2 '
                         f'({STREAM_PREFIX}...) among its streams ({names}); need one')
    markers = found[0]
    session = Session(path=str(path), namespace=_first(markers['info'].get('name'))[
        len(STREAM_PREFIX):].strip())
    events = [(float(t), parse_marker(text[0])) for t, text in
              zip(markers['time_stamps'], markers['time_series'])]
    add_events(session, sorted(events, key=lambda event: event[0]))
    try:
        gaze = pick_gaze_stream(streams, profile=profile)
        points = gaze_from_stream(gaze, profile, screen, source_size)
    except RecordingError:
        gaze, points = None, np.zeros((0, 2))
    if gaze is not None:
        stamps = np.asarray(gaze['time_stamps'], dtype=float)
        keep = np.all(np.isfinite(points), axis=1)
        order = np.argsort(stamps[keep], kind='stable')
        session.gaze_t, session.gaze_xy = stamps[keep][order], points[keep][order]
    times = [t for t, _ in events] + list(session.gaze_t[:1]) + list(session.gaze_t[-1:])
    if times:
        session.start, session.end = min(times), max(times)
    session.counts = {'markers': len(events), 'gaze/samples': len(session.gaze_t)}
    return session


def clock_offset(bag: Session, xdf: Session) -> float:
    """
    Return the ROS clock minus the XDF's clock, s, from the questions both recorded.

    Each question is marked when it is asked and the bag holds its reception: the median
    difference over the questions.  NaN when their counts differ (not the same session).
    """
    if not bag.requests or len(bag.requests) != len(xdf.requests):
        return float('nan')
    return float(np.median(np.subtract(sorted(bag.requests), sorted(xdf.requests))))


def cross_check(bag: Session, xdf: Session) -> Dict:
    """
    Compare a session's bag and XDF: what each holds, the clock offset, each choice's lag.

    :returns: plain data for the report: counts in both, the offset (ROS - XDF, s) and,
        per choice, the time from its last gaze sample (the XDF marker's stamp) to the bag's
        reception of ``choice`` (s).
    """
    offset = clock_offset(bag, xdf)
    same = [a == b for (_, a), (_, b) in zip(bag.choices, xdf.choices)]
    lags = [t_bag - (t_xdf + offset) for (t_bag, _), (t_xdf, _)
            in zip(bag.choices, xdf.choices)] if np.isfinite(offset) else []
    return {'xdf': xdf.path,
            'questions': [len(bag.requests), len(xdf.requests)],
            'choices': [len(bag.choices), len(xdf.choices)],
            'no_choice_rounds': [len(bag.no_choices), len(xdf.no_choices)],
            'goals': [len(bag.goals), len(xdf.goals)],
            'same_choices': len(bag.choices) == len(xdf.choices) and all(same),
            'clock_offset_s': offset, 'choice_lag_s': lags,
            'xdf_gaze_samples': len(xdf.gaze_t)}
