"""
The report of a recorded session: pictures and a summary, from its rosbag2.

``session_report BAG [XDF] [-o FOLDER]`` reads a session recorded by
``session_record`` (or ``ros2 bag record`` of the same topics,
:mod:`eye_bci_ros2.ros.session_topics`), or LabRecorder's XDF of it alone
(:mod:`eye_bci_ros2.experiments.session_xdf`: the pipeline's markers and the gaze; no
cue, map or odometry), and writes into FOLDER (default ``BAG/report``, ``XDF``'s name
without ``.xdf``, ``_report``):

* ``question_NNN.png`` per question answered (``choice/request`` followed by a
  ``choice``): the person's screen, the options offered (``choices/regions``
  at the choice) in their colours (``choices``), the gaze from the question to
  the choice (green: inside an option's outline shown at the sample's own time,
  red: outside), the choice and, in cued runs, the intended option (``experiment/cue``)
  as a star;
* ``drive_NN.png`` per robot drive (a ``goal_pose``, else the menu's ``go``, to the
  menu's next word on the drive: arrived, stopped, failed): the map, the plan
  and the path driven (the action's feedback poses, in the map frame; else ``odom``);
* ``timeline.png``: questions, choices, rounds without a choice, drives and
  the gaze rate over the session;
* with both, ``report.json``'s ``xdf`` compares them: the questions, choices, rounds
  without a choice and goals each holds, the offset between their clocks and each
  choice's lag from its last gaze sample (the XDF's stamp) to the bag's reception;
* ``report.json`` and ``questions.csv``: each question (offered, chosen,
  intended, correct, time from the question to the choice, time from the
  options appearing to the choice), choices made with no question asked
  (``unasked_choices``), drives, and accuracy and ITR (Wolpaw; N = options
  offered, T = time per selection) over the cued questions.

The demo (``make demo``) records its own session and writes its pictures
with this module: one path for the simulated and the real.  docs/recording.md
says how a study records.
"""

import argparse
import csv
from dataclasses import asdict, dataclass, field, replace
import json
import math
import os
import sys
from typing import List, Optional, Sequence, Tuple

import numpy as np

from eye_bci_ros2.decision.regions import classify_against_history, RegionSet
from eye_bci_ros2.experiments import render
from eye_bci_ros2.experiments.metrics import itr_bits_per_minute
from eye_bci_ros2.experiments.session_bag import read_session, Session
from eye_bci_ros2.experiments.session_xdf import cross_check, read_xdf_session, XDF_SUFFIXES
from eye_bci_ros2.projection.camera_model import DEFAULT_IMAGE_SIZE, DEFAULT_PANEL_OFFSET
from eye_bci_ros2.projection.visual_angle import DEFAULT_VIEWING
from eye_bci_ros2.recordings.session_markers import ARRIVED, FAILED, progress_event, STOPPED

#: The screen and RViz panel the pictures draw when not told (the package's defaults).
SCREEN_SIZE = (DEFAULT_VIEWING.width_px, DEFAULT_VIEWING.height_px)
PANEL = (float(DEFAULT_PANEL_OFFSET[0]), float(DEFAULT_PANEL_OFFSET[1]),
         float(DEFAULT_IMAGE_SIZE[0]), float(DEFAULT_IMAGE_SIZE[1]))
#: The ``choice_menu/progress`` events that end a drive (sending, driving, stopping, no
#: feedback yet: the drive goes on).
DRIVE_ENDS = (ARRIVED, STOPPED, FAILED)
#: Colours of the timeline.
_CORRECT, _WRONG, _UNCUED, _NONE, _DRIVE = '#20c060', '#ff3030', '#4080ff', '#a0a0a0', '#ffb000'


@dataclass
class Question:
    """
    One question: asked (``choice/request``), ended by a choice or a round without one.

    Times are s on the ROS clock.  ``intended`` is the cue in force at the end ('' = none).
    """

    index: int
    asked: float
    ended: float
    shown: float
    offered: List[str]
    chosen: Optional[str]
    reason: str = ''
    intended: str = ''
    gaze_samples: int = 0
    in_region_samples: int = 0
    picture: str = ''

    @property
    def decision_time_s(self) -> float:
        """Return the time from the question to its end, s."""
        return self.ended - self.asked

    @property
    def selection_time_s(self) -> float:
        """Return the time from the options appearing to the end, s."""
        return self.ended - self.shown

    @property
    def correct(self) -> Optional[bool]:
        """Tell whether the choice was the cued option (None when nothing was cued or chosen)."""
        if not self.intended or self.chosen is None:
            return None
        return self.chosen == self.intended

    def as_row(self) -> dict:
        """Return the question as plain data."""
        row = asdict(self)
        row.update(decision_time_s=self.decision_time_s,
                   selection_time_s=self.selection_time_s, correct=self.correct)
        return row


@dataclass
class Drive:
    """A robot drive: when it began and ended, how, and where the robot went."""

    index: int
    start: float
    end: float
    outcome: str
    goal: Optional[List[float]]
    path_m: float
    arrived: bool
    picture: str = ''
    path: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)), repr=False)
    plan: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)), repr=False)

    def as_row(self) -> dict:
        """Return the drive as plain data (without the arrays)."""
        return {'index': self.index, 'start': self.start, 'end': self.end,
                'duration_s': self.end - self.start, 'outcome': self.outcome,
                'goal': self.goal, 'path_m': self.path_m, 'arrived': self.arrived,
                'picture': self.picture}


@dataclass
class Report:
    """What the report found in a session."""

    session: Session
    questions: List[Question]
    unasked_choices: List[Tuple[float, str]]
    drives: List[Drive]
    accuracy: float
    cued: int
    mean_decision_s: float
    mean_selection_s: float
    itr_bits_per_min: float
    files: List[str] = field(default_factory=list)
    #: The comparison with the session's XDF (``session_xdf.cross_check``), when given.
    xdf: Optional[dict] = None


def _between(events, start: float, end: float):
    return [(t, text) for t, text in events if start <= t < end]


def _shown_since(regions: Sequence[RegionSet], labels: Sequence[str], at: float) -> float:
    """When the options ``labels`` appeared (the first of the unbroken sets showing them)."""
    since = at
    for regions_set in reversed([r for r in regions if r.stamp <= at]):
        if set(regions_set.labels) != set(labels):
            break
        since = regions_set.stamp
    return since


def _regions_at(regions: Sequence[RegionSet], at: float) -> Optional[RegionSet]:
    shown = [r for r in regions if r.stamp <= at]
    return shown[-1] if shown else None


def find_questions(session: Session) -> Tuple[List[Question], List[Tuple[float, str]]]:
    """
    Pair each question with the choice or the round without one that ended it.

    :returns: the questions, and the choices made with no question open.
    """
    questions: List[Question] = []
    used = set()
    previous_end = -math.inf
    requests = sorted(session.requests)
    for index, asked in enumerate(requests):
        limit = requests[index + 1] if index + 1 < len(requests) else math.inf
        choices = _between(session.choices, asked, limit)
        nones = _between(session.no_choices, asked, limit)
        first_choice = choices[0] if choices else None
        first_none = nones[0] if nones else None
        if first_choice is None and first_none is None:
            continue    # still open when the recording stopped
        if first_choice is not None and (first_none is None or first_choice[0] <= first_none[0]):
            ended, chosen, reason = first_choice[0], first_choice[1], ''
            used.add(first_choice)
        else:
            ended, chosen, reason = first_none[0], None, first_none[1]
        shown_set = _regions_at(session.regions, ended)
        offered = list(shown_set.labels) if shown_set is not None else []
        cues = [text for t, text in session.cues if t <= ended]
        questions.append(Question(
            index=len(questions) + 1, asked=asked, ended=ended,
            shown=min(asked, max(previous_end, _shown_since(session.regions, offered, ended))),
            offered=offered, chosen=chosen, reason=reason,
            intended=cues[-1] if cues else ''))
        previous_end = ended
    unasked = [choice for choice in session.choices if choice not in used]
    return questions, unasked


def find_drives(session: Session) -> List[Drive]:
    """Find each drive: from a goal (else a 'go' answer) to the menu's word that ended it."""
    starts = [t for t, _ in session.goals] or [t for t, text in session.answers if text == 'go']
    drives = []
    for index, start in enumerate(starts):
        limit = starts[index + 1] if index + 1 < len(starts) else math.inf
        ending = [(t, text) for t, text in session.progress
                  if start <= t < limit and progress_event(text) in DRIVE_ENDS]
        end, outcome = ending[0] if ending else (min(limit, session.end), 'recording ended')
        # The feedback's current_pose is the robot in the map frame; odometry is in its own
        # drifting odom frame (REP-105), drawn only where a recording has no feedback.
        poses = session.robot_poses if len(session.robot_poses) else session.odometry
        driven = poses[(poses[:, 0] >= start - 0.05) & (poses[:, 0] <= end + 0.05)]
        steps = np.diff(driven[:, 1:3], axis=0)
        plans = [plan for t, plan in session.plans if start - 0.5 <= t <= end and len(plan)]
        goals = [pose for t, pose in session.goals if start - 0.5 <= t <= end]
        goal = [round(float(v), 4) for v in goals[0]] if goals else None
        drives.append(Drive(
            index=index + 1, start=start, end=end, outcome=outcome, goal=goal,
            path_m=float(np.sum(np.hypot(steps[:, 0], steps[:, 1]))) if len(steps) else 0.0,
            arrived=outcome.startswith('arrived'), path=driven[:, 1:],
            plan=plans[-1] if plans else np.zeros((0, 2))))
    return drives


def build_report(session: Session) -> Report:
    """Find the questions, the unasked choices and the drives; compute accuracy and ITR."""
    questions, unasked = find_questions(session)
    answered = [q for q in questions if q.chosen is not None]
    cued = [q for q in answered if q.correct is not None]
    accuracy = sum(q.correct for q in cued) / len(cued) if cued else math.nan
    decision = float(np.mean([q.decision_time_s for q in answered])) if answered else math.nan
    selection = float(np.mean([q.selection_time_s for q in answered])) if answered else math.nan
    itr = (itr_bits_per_minute([len(q.offered) for q in cued], accuracy, selection)
           if cued else math.nan)
    return Report(session=session, questions=questions, unasked_choices=unasked,
                  drives=find_drives(session), accuracy=accuracy, cued=len(cued),
                  mean_decision_s=decision, mean_selection_s=selection, itr_bits_per_min=itr)


def _screen_picture(report: Report, question: Question, screen_size, panel
                    ) -> render.ScreenPicture:
    session = report.session
    use = (session.gaze_t >= question.asked) & (session.gaze_t <= question.ended)
    stamps, points = session.gaze_t[use], session.gaze_xy[use]
    inside = classify_against_history(stamps, points, session.regions)
    question.gaze_samples, question.in_region_samples = len(stamps), int(inside.sum())
    shown = _regions_at(session.regions, question.ended)
    regions = dict(zip(shown.labels, shown.polygons)) if shown is not None else {}
    target = np.zeros((0, 2))
    if question.intended in regions:
        outline = regions[question.intended]
        target = np.nanmean(outline, axis=0).reshape(1, 2)
    verdict = {True: 'CORRECT', False: 'WRONG', None: 'no cue'}[question.correct]
    chosen = (f"'{question.chosen}'" if question.chosen is not None
              else f'nothing ({question.reason})')
    title = (f'Question {question.index}: chosen {chosen}'
             + (f", intended '{question.intended}' -> {verdict}" if question.intended else ''))
    details = [f'{len(stamps)} gaze samples from the question to the choice, '
               f'{question.in_region_samples} inside an option; answered '
               f'{question.decision_time_s:.2f} s after the question, '
               f'{question.selection_time_s:.2f} s after the options appeared',
               f'offered: {", ".join(question.offered) or "nothing on the screen"}']
    return render.ScreenPicture(
        title=title, details=details, screen_size=screen_size, panel=panel, regions=regions,
        colours={label: session.colours[label] for label in regions
                 if label in session.colours},
        gaze=points, gaze_in_region=inside, chosen=question.chosen,
        intended=question.intended or None, target_path=target,
        rule='gaze: green inside an option shown at its time, red outside')


def _drive_picture(session: Session, drive: Drive) -> render.DrivePicture:
    grid = session.map
    goal = np.array(drive.goal) if drive.goal is not None else None
    verdict = 'ARRIVED' if drive.arrived else drive.outcome.upper()
    return render.DrivePicture(
        title=f'Drive {drive.index}: {verdict}',
        details=[f'{drive.path_m:.1f} m driven in {drive.end - drive.start:.1f} s '
                 f'(recorded time); menu: {drive.outcome}'],
        occupancy=grid.occupancy if grid is not None else None,
        origin=grid.origin if grid is not None else (0.0, 0.0),
        resolution=grid.resolution if grid is not None else 0.05,
        path=drive.path[:, :2], plan=drive.plan, goal=goal,
        robot=drive.path[-1] if len(drive.path) else None)


def _timeline(report: Report) -> render.TimelinePicture:
    session = report.session
    origin = session.start if math.isfinite(session.start) else 0.0
    colour = {True: _CORRECT, False: _WRONG, None: _UNCUED}
    questions = [(q.asked - origin, q.ended - origin,
                  colour[q.correct] if q.chosen is not None else _NONE,
                  q.chosen or '') for q in report.questions]
    drives = [(d.start - origin, d.end - origin, _DRIVE, d.outcome.split(':')[0])
              for d in report.drives]
    rate = None
    if len(session.gaze_t) > 1:
        edges = np.arange(session.gaze_t[0], session.gaze_t[-1] + 1.0, 1.0)
        counts, _ = np.histogram(session.gaze_t, edges)
        rate = (edges[:-1] - origin + 0.5, counts.astype(float))
    return render.TimelinePicture(
        title=f'Session {os.path.basename(os.path.normpath(session.path))}: '
              f'{len(report.questions)} questions, {len(report.drives)} drives',
        spans={'questions': questions, 'drives': drives},
        ticks={'choices': [(t - origin, _UNCUED, text) for t, text in session.choices],
               'no choice': [(t - origin, _NONE, '') for t, _ in session.no_choices],
               'unasked': [(t - origin, _WRONG, text) for t, text in report.unasked_choices],
               'answers': [(t - origin, '#000000', text) for t, text in session.answers]},
        rate=rate)


def write_report(report: Report, folder: str, pictures: bool = True,
                 screen_size: Tuple[int, int] = SCREEN_SIZE,
                 panel: Tuple[float, float, float, float] = PANEL) -> List[str]:
    """Write the pictures, ``report.json`` and ``questions.csv``; return the files."""
    os.makedirs(folder, exist_ok=True)
    files = []
    for question in report.questions:
        picture = _screen_picture(report, question, screen_size, panel)
        if pictures and question.chosen is not None:
            question.picture = render.render_screen(
                picture, os.path.join(folder, f'question_{question.index:03d}.png'))
            files.append(question.picture)
    if pictures:
        for drive in report.drives:
            drive.picture = render.render_drive(
                _drive_picture(report.session, drive),
                os.path.join(folder, f'drive_{drive.index:02d}.png'))
            files.append(drive.picture)
        files.append(render.render_timeline(_timeline(report),
                                            os.path.join(folder, 'timeline.png')))
    session = report.session
    summary = {
        'bag': session.path, 'namespace': session.namespace,
        'start': session.start, 'end': session.end, 'messages': session.counts,
        'gaze_samples': len(session.gaze_t),
        'questions': [q.as_row() for q in report.questions],
        'answered': sum(q.chosen is not None for q in report.questions),
        'no_choice_rounds': sum(q.chosen is None for q in report.questions),
        'unasked_choices': [{'time': t, 'label': text} for t, text in report.unasked_choices],
        'drives': [d.as_row() for d in report.drives],
        'cued': report.cued, 'accuracy': report.accuracy,
        'mean_decision_time_s': report.mean_decision_s,
        'mean_time_per_selection_s': report.mean_selection_s,
        'itr_bits_per_min': report.itr_bits_per_min,
        'itr_formula': 'Wolpaw: B = log2 N + P log2 P + (1-P) log2((1-P)/(N-1)), averaged '
                       'over the cued questions answered (N = options offered), ITR = B * 60 / '
                       'T (T = mean time from the options appearing to the choice)',
        'validations': [{'time': t, 'result': text} for t, text in session.validations],
        'xdf': report.xdf,
    }
    path = os.path.join(folder, 'report.json')
    with open(path, 'w', encoding='utf-8') as stream:
        # Strict JSON (a lab's parser in any language): what is unknown is null, not NaN.
        json.dump(_json_safe(json.loads(json.dumps(summary, default=render.json_default))),
                  stream, indent=2, allow_nan=False)
    files.append(path)
    path = os.path.join(folder, 'questions.csv')
    columns = ['index', 'asked', 'ended', 'offered', 'chosen', 'reason', 'intended', 'correct',
               'decision_time_s', 'selection_time_s', 'gaze_samples', 'in_region_samples',
               'picture']
    with open(path, 'w', newline='', encoding='utf-8') as stream:
        writer = csv.DictWriter(stream, fieldnames=columns, extrasaction='ignore')
        writer.writeheader()
        for question in report.questions:
            row = question.as_row()
            writer.writerow({**row, 'offered': ' '.join(row['offered']),
                             'picture': os.path.basename(row['picture'])})
    files.append(path)
    report.files = files
    return files


def _json_safe(value):
    """Return ``value`` with every NaN or infinity replaced by None."""
    if isinstance(value, dict):
        return {key: _json_safe(item) for key, item in value.items()}
    if isinstance(value, list):
        return [_json_safe(item) for item in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def summary_line(report: Report) -> str:
    """Return the report in one line (what the terminal shows)."""
    answered = [q for q in report.questions if q.chosen is not None]
    accuracy = (f'accuracy {100 * report.accuracy:.1f} % over {report.cued} cued'
                if report.cued else 'no cues (accuracy unknown)')
    return (f'{len(report.questions)} questions, {len(answered)} answered, '
            f'{len(report.unasked_choices)} choices with no question, '
            f'{len(report.drives)} drives; {accuracy}; mean {report.mean_decision_s:.2f} s '
            f'question to choice, {report.mean_selection_s:.2f} s per selection'
            + (f'; ITR {report.itr_bits_per_min:.1f} bits/min' if report.cued else ''))


def _pair(text: str, kind=int, count: int = 2, sep: str = 'x') -> Tuple:
    parts = text.replace(',', sep).split(sep)
    if len(parts) != count:
        raise argparse.ArgumentTypeError(f"'{text}': expected {count} numbers")
    try:
        return tuple(kind(part) for part in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}': expected numbers") from None


def build_parser() -> argparse.ArgumentParser:
    """Return the command-line options of ``session_report``."""
    parser = argparse.ArgumentParser(prog='session_report',
                                     description=__doc__.strip().splitlines()[0])
    parser.add_argument('paths', nargs='+', metavar='BAG|XDF',
                        help='the session bag folder (session_record, ros2 bag record), '
                             "LabRecorder's XDF file of it, or both")
    parser.add_argument('-o', '--output', default=None,
                        help='where the report goes (default BAG/report, else XDF_report)')
    parser.add_argument('--profile', default=None,
                        help="the XDF gaze stream's tracker layout (default: from the stream)")
    parser.add_argument('--screen', type=_pair, default=SCREEN_SIZE,
                        help='the screen, WIDTHxHEIGHT px (default %dx%d)' % SCREEN_SIZE)
    parser.add_argument('--panel', type=lambda text: _pair(text, float, 4, ','),
                        default=PANEL, help='the RViz panel on the screen, X,Y,WIDTH,HEIGHT '
                        'px (default %g,%g,%g,%g)' % PANEL)
    parser.add_argument('--no-pictures', action='store_true', help='the summary only')
    return parser


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Write the report of a bag; 1 with one line when it cannot be read."""
    parser = build_parser()
    args = parser.parse_args(argv)
    xdfs = [p for p in args.paths if p.lower().endswith(XDF_SUFFIXES)]
    bags = [p for p in args.paths if p not in xdfs]
    if len(xdfs) > 1 or len(bags) > 1:
        parser.error('give one bag, one XDF file, or one of each')
    try:
        xdf = (read_xdf_session(xdfs[0], args.profile,
                                replace(DEFAULT_VIEWING, width_px=args.screen[0],
                                        height_px=args.screen[1]))
               if xdfs else None)
        report = build_report(read_session(bags[0]) if bags else xdf)
    except ValueError as error:
        print(f'session_report: {error}', file=sys.stderr)
        return 1
    if bags and xdf is not None:
        report.xdf = cross_check(report.session, xdf)
    folder = args.output or (os.path.join(bags[0], 'report') if bags else
                             os.path.splitext(xdfs[0])[0] + '_report')
    files = write_report(report, folder, pictures=not args.no_pictures,
                         screen_size=args.screen, panel=args.panel)
    print(f'session_report: {summary_line(report)}')
    print(f'session_report: wrote {len(files)} files to {folder}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
