"""
Benchmark: which validation correction real trackers need, judged on targets left out of the fit.

For every 9-point validation recording in the data folder (the ETDQualitizer
``etdq_*`` files: EyeLink 1000 Plus, SMI RED500, Tobii Pro Spectrum; or any
recording :func:`eye_bci_ros2.recordings.gaze.load_gaze` reads with 9 or more
targets), the gaze of each target while it is shown still (from ``--settle``
s after it stops) is averaged, and each kind of correction of
:func:`eye_bci_ros2.gaze.validation.fit_correction` (offset, affine,
second-order) is fitted to all targets but one and judged at the one left
out (:func:`eye_bci_ros2.gaze.validation.held_out_errors`).  Reported per
recording, degrees of visual angle: the error before any correction, each
kind's mean held-out error, and what ``gaze_validation``'s ``kind: auto``
does with the recording (the kind it fits and its held-out error, or why it
refuses), including the plausibility checks over the whole screen.

The ETDQualitizer targets cover the middle half of the screen (+-480 x
+-270 px on 1920 x 1080), so a second-order fit there is judged far outside
the targets (the node's own layout reaches 10 % from the panel's edges).

Run: ``python -m bench.correction_fit [--data DIR] [--settle S]`` (a few
seconds; ``DIR`` defaults to ``../shared/data/real_gaze`` beside the
repository, or ``$EYE_BCI_DATA/real_gaze``).
"""

import argparse
import math
import sys
from typing import Dict, List, Optional, Sequence

import numpy as np

from eye_bci_ros2.gaze.validation import (CorrectionRefused, fit_correction, held_out_errors,
                                          KINDS, measure, MIN_TARGETS, samples_per_target)
from eye_bci_ros2.recordings import find_data
from eye_bci_ros2.recordings.gaze import find_recordings, GazeRecording, load_gaze

#: Default time after a target stops moving before its gaze is used, s (the ETDQualitizer
#: dot shrinks in place for 0.4 s before it counts as still: the eye is there already).
SETTLE_S = 0.2


def evaluate(recording: GazeRecording, settle_s: float = SETTLE_S) -> Dict[str, object]:
    """
    Return one recording's row: errors before, per kind held out, and the auto outcome.

    :returns: ``{'tracker', 'targets', 'before_deg', '<kind>_deg' per kind of
        :data:`~eye_bci_ros2.gaze.validation.KINDS`, 'auto', 'auto_deg', 'reason'}``
        (``auto`` = the kind fitted or 'refused'; ``reason`` = why refused, or
        the fit's note).
    """
    schedule = recording.targets
    samples = samples_per_target(recording.stamps, recording.points, schedule.still,
                                 schedule.ends, settle_s)
    report = measure(schedule.places, samples, recording.screen)
    measured = np.array([t.mean_px for t in report.targets])
    row: Dict[str, object] = {'tracker': recording.tracker or recording.name,
                              'targets': len(schedule), 'before_deg': report.accuracy_deg}
    for kind in KINDS:
        row[f'{kind}_deg'] = (float(np.mean(held_out_errors(measured, schedule.places, kind,
                                                            recording.screen)))
                              if not report.missing else math.nan)
    try:
        fit = fit_correction(schedule.places, samples, screen=recording.screen)
        row.update(auto=fit.kind, auto_deg=fit.held_out_deg, reason=fit.note)
    except CorrectionRefused as refused:
        row.update(auto='refused', auto_deg=math.nan, reason=str(refused))
    return row


def validation_recordings(folder) -> List[GazeRecording]:
    """Load the recordings of ``folder`` that are validations (9 or more still targets)."""
    loaded = [load_gaze(path) for path in find_recordings(folder)
              if path.name.startswith('etdq_') or path.name.endswith(('.gaze.csv',
                                                                     '.gaze.csv.gz'))]
    return [r for r in loaded if len(r.targets) >= MIN_TARGETS['quadratic']]


def run(quick: bool = False, data: Optional[str] = None,
        settle_s: float = SETTLE_S) -> Dict[str, Dict[str, object]]:
    """
    Evaluate every validation recording of ``data`` (default: the shared folder).

    :returns: ``{recording name: row}`` (:func:`evaluate`); ``{'skipped': {'reason':
        ...}}`` when there is no data.
    """
    folder = data or find_data('real_gaze')
    if folder is None:
        return {'skipped': {'reason': 'no real_gaze folder (give --data DIR or set '
                            'EYE_BCI_DATA)'}}
    return {r.name: evaluate(r, settle_s) for r in validation_recordings(folder)}


def format_lines(section: Dict[str, Dict[str, object]]) -> List[str]:
    """Return the table: one line per recording, then the reasons."""
    if 'skipped' in section:
        return [f"skipped: {section['skipped']['reason']}"]
    head = (f"{'tracker':32s} {'none':>5s} " + ' '.join(f'{k:>9s}' for k in KINDS)
            + f"  {'auto':>9s} {'held out':>8s}")
    lines = ['mean error at each target, deg: before, and each fit made without that target',
             head, '-' * len(head)]
    notes = []
    for row in section.values():
        lines.append(f"{row['tracker']:32s} {row['before_deg']:5.2f} "
                     + ' '.join(f"{row[f'{k}_deg']:9.2f}" for k in KINDS)
                     + f"  {row['auto']:>9s} {row['auto_deg']:8.2f}")
        if row['reason']:
            notes.append(f"{row['tracker']}: {row['reason']}")
    return lines + notes


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Print the table; status 1 when there is no data."""
    parser = argparse.ArgumentParser(prog='python -m bench.correction_fit',
                                     description=__doc__.strip().splitlines()[0])
    parser.add_argument('--data', help='folder of gaze recordings (default: the shared '
                        'real_gaze folder)')
    parser.add_argument('--settle', type=float, default=SETTLE_S,
                        help='s after a target stops before its gaze is used '
                        '(default %(default)s)')
    args = parser.parse_args(argv)
    section = run(data=args.data, settle_s=args.settle)
    print('\n'.join(format_lines(section)))
    return 1 if 'skipped' in section else 0


if __name__ == '__main__':
    sys.exit(main())
