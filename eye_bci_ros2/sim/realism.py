"""
The simulated person beside real people: the same statistics on the same target schedules.

Each real recording's schedule and screen are given to the simulated person
(:func:`~eye_bci_ros2.sim.person.record_schedule`, a preset at the recording's
own rate) and both are measured by :mod:`eye_bci_ros2.recordings.gaze_statistics`::

    python -m eye_bci_ros2.sim.realism ../shared/data/real_gaze --match X260
    python -m eye_bci_ros2.sim.realism DIR --match Spectrum --preset pro_tracker_1200hz

``test/sim/test_person_realism.py`` holds the figures to stated tolerances.
"""

import argparse
from pathlib import Path
from typing import Optional, Sequence, Tuple

from eye_bci_ros2.recordings.gaze import find_recordings, GazeRecording, load_gaze, RecordingError
from eye_bci_ros2.recordings.gaze_statistics import gaze_statistics, GazeStatistics
from eye_bci_ros2.sim.person import CONSUMER_TRACKER, GazeParams, PRESETS, record_schedule


def simulate_like(params: GazeParams,
                  real: Sequence[GazeRecording]) -> Tuple[GazeRecording, ...]:
    """
    Record the simulated person on each real recording's schedule, screen and rate.

    Seeds 0, 1, ... in the order given: one simulated person per real one.
    """
    return tuple(record_schedule(recording.targets, recording.screen, params,
                                 rate_hz=round(recording.rate_hz), seed=seed,
                                 name=f'simulated {recording.name}')
                 for seed, recording in enumerate(real))


def compare(params: GazeParams, real: Sequence[GazeRecording]) -> Tuple[GazeStatistics,
                                                                        GazeStatistics]:
    """Return the statistics of the real recordings and of the simulated person on them."""
    return gaze_statistics(real), gaze_statistics(simulate_like(params, real))


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Print real and simulated statistics side by side; returns the exit code."""
    parser = argparse.ArgumentParser(prog='python -m eye_bci_ros2.sim.realism',
                                     description=__doc__.strip().split('\n\n')[0])
    parser.add_argument('folder', help='a folder of gaze recordings (any format load_gaze reads)')
    parser.add_argument('--match', default='', help='only the files whose name contains this')
    parser.add_argument('--preset', choices=sorted(PRESETS), default=CONSUMER_TRACKER.name,
                        help='the simulated person and tracker')
    args = parser.parse_args(argv)
    try:
        real = [load_gaze(path) for path in find_recordings(Path(args.folder))
                if args.match in path.name]
    except RecordingError as error:
        parser.error(str(error))
    real = [recording for recording in real if len(recording.targets)]
    if not real:
        parser.error(f"no recording with targets in {args.folder} matching '{args.match}'")
    measured, simulated = compare(PRESETS[args.preset], real)
    names = ', '.join(recording.name for recording in real)
    print(f"{len(real)} recording(s): {names}; simulated: {args.preset} at each one's rate")
    print(f"{'':22s} {'real':>9s} {'simulated':>9s}")
    for name, value in measured.as_dict().items():
        other = simulated.as_dict()[name]
        print(f'{name:22s} {value:9.3f} {other:9.3f}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
