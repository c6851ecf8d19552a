"""
Run the benchmarks, print each section as it finishes and write ``bench_results.json``.

``make bench`` runs ``python -m bench.run_all``: the **default run**, every
section at a size that still says what it measures (fewer trials, sizes or
seconds than the complete run; each section's output says what was shortened)
so that it finishes in about ten minutes on a 2-core machine.  ``--full`` runs
the complete tables (tens of minutes), ``--quick`` each section's smoke sizes
(rough numbers, for checking the plumbing).  Progress (which section, how many
done, elapsed time, and a line every :data:`HEARTBEAT_S` while a long section
runs) goes to stderr; each section's table goes to stdout as soon as it
finishes, and the JSON file is rewritten after every section, so an
interrupted run keeps what finished.

Every benchmark is a module with ``run(quick: bool = False, **sizes) -> dict``
returning its section of the results (``{row: {metric: value}}``, e.g.
``{'1000': {'ms': 1.2}}``); :data:`REGISTRY` names them and :data:`DEFAULT_RUN`
gives the keyword arguments of their default run and what they leave out.  A
module that does not exist yet, whose ``unavailable() -> str`` gives a reason,
or whose recordings are absent (:data:`NEEDS_DATA`; ``--gaze-data`` and
``--eeg-data`` name the folders, passed on as ``data``) is reported as skipped
with the reason; any other failure is recorded in the JSON and makes the exit
status 1, after the other benchmarks have run, as does a row whose ``agrees``
is false (fast path and reference disagree).  A module may name the metrics
its table shows in ``TABLE_COLUMNS`` (default: all), or print its own table:
``format_lines(section) -> list[str]`` (used when present, e.g. for a nested
section such as ``bench.decision``'s).

Usage::

    python -m bench.run_all [--full | --quick] [--only NAME[,NAME]] [--output PATH]
                            [--gaze-data DIR] [--eeg-data DIR]

With ``--only`` the sections already in the output file are kept and only the
named ones are replaced.
"""

import argparse
import datetime
import importlib
import json
import math
import os
import resource
import sys
import threading
import time
import traceback
from typing import Callable, Dict, List, Optional, Sequence, TextIO

from bench.timing import machine_info
from eye_bci_ros2.ros.startup import quiet_liblsl

#: Benchmark name -> module providing ``run(quick=False, **sizes) -> dict``, in run order.
REGISTRY: Dict[str, str] = {
    'projection': 'bench.projection',
    'arbitration': 'bench.arbitration',
    'latency': 'bench.latency',
    'lab_rate': 'bench.lab_rate',
    'real_gaze': 'bench.real_gaze',
    'decision': 'bench.decision',
    'tolerance': 'bench.tolerance',
    'validation': 'bench.validation',
    'correction_fit': 'bench.correction_fit',
    'calibration': 'bench.calibration_protocol',
    'ssvep': 'bench.ssvep',
    'ssvep_real': 'bench.ssvep_real',
    'real_hybrid': 'bench.real_hybrid',
    'robot': 'bench.robot',
}

#: The default run of a section: ``(keyword arguments of run(), what that leaves out of
#: the complete run)``; the arguments may be a function of the section's module (for
#: its own constants).  A section not named runs complete.  The sizes keep what each
#: section measures (every rate, scenario, rule and person) and shorten how many times
#: it is measured (trials, sizes, seconds); docs/performance.md has the time of each
#: section in both runs.  The figures in the docs come from the complete runs.
DEFAULT_RUN: Dict[str, tuple] = {
    'real_gaze': ({'sizes': (100, 200)},
                  'options of 100 and 200 px only (complete: 16, 32, 64, 100, 200)'),
    'decision': (lambda module: {'trials': 50, 'tuning_trials': 25, 'fast_trials': 8,
                                 'grid': module.QUICK_GRID},
                 '50 test trials per cell (complete: 200), 25 tuning trials (100), 8 at '
                 '1200 Hz (30); the count rule tuned over 4 early-decision settings (60)'),
    'tolerance': ({'trials': 30}, '30 trials per cell (complete: 100); the binary search '
                                  'complete'),
    'ssvep': ({'cpu_duration_s': 20.0},
              'the CPU part decodes 20 s of EEG per set-up (complete: 60 s)'),
    'ssvep_real': ({'null_rounds': False},
                   'without the white-noise rounds (complete: with them, about 1.5 minutes '
                   'more)'),
}

#: Sections that need real recordings: name -> kind (``find_data`` folder name).
NEEDS_DATA: Dict[str, str] = {'real_gaze': 'real_gaze', 'correction_fit': 'real_gaze',
                              'ssvep_real': 'real_eeg'}
#: Sections that need both kinds: ``--gaze-data`` and ``--eeg-data`` are passed on as
#: ``gaze_data`` and ``eeg_data`` (their ``unavailable()`` says when one is missing).
NEEDS_BOTH = ('real_hybrid',)

#: The runs: ``quick`` (smoke sizes), ``default`` (:data:`DEFAULT_RUN`), ``full``.
MODES = ('quick', 'default', 'full')

#: Seconds between "still running" lines while a section runs.
HEARTBEAT_S = 60.0

#: Default output: bench_results.json at the repository root.
DEFAULT_OUTPUT = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                              'bench_results.json')


class NotAvailable(Exception):
    """The benchmark's module is not written yet."""


def load(name: str):
    """
    Import the module of benchmark ``name``.

    :raises KeyError: ``name`` is not in :data:`REGISTRY`.
    :raises NotAvailable: its module does not exist (yet).
    """
    module_name = REGISTRY[name]
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as error:
        if error.name != module_name:
            raise  # the module exists but something it imports is missing
        raise NotAvailable(f'{module_name} does not exist yet') from None
    return module


def run_arguments(name: str, mode: str, module=None) -> tuple:
    """
    Keyword arguments of section ``name``'s ``run()`` in ``mode``, and what they leave out.

    :param module: the section's module (for arguments that name its constants).
    :returns: ``(kwargs, shortened)``; ``shortened`` is '' for a complete run.
    """
    if mode == 'quick':
        return {'quick': True}, 'quick: smoke sizes, rough numbers'
    if mode == 'default' and name in DEFAULT_RUN:
        kwargs, shortened = DEFAULT_RUN[name]
        return dict(kwargs(module) if callable(kwargs) else kwargs), shortened
    return {}, ''


def data_folder(name: str, folders: Dict[str, Optional[str]]) -> tuple:
    """
    Find the recordings folder section ``name`` is given, or say why it cannot run.

    :param folders: kind -> folder named on the command line (None: find it).
    :returns: ``(folder or None, reason or None)``; ``(None, None)`` when the
        section needs no recordings or finds them itself.
    """
    kind = NEEDS_DATA.get(name)
    if kind is None:
        return None, None
    named = folders.get(kind)
    option = '--eeg-data' if kind == 'real_eeg' else '--gaze-data'
    if named:
        if not os.path.isdir(named):
            return None, f'{option} {named} is not a folder'
        return named, None
    from eye_bci_ros2.recordings import find_data
    if kind == 'real_gaze' and find_data(kind) is None:
        return None, (f'no real gaze recordings (../shared/data/real_gaze, $EYE_BCI_DATA, '
                      f'or {option} DIR)')
    return None, None   # found, or the module's unavailable() says why not


def _both(folders: Optional[Dict[str, str]]) -> Dict[str, Optional[str]]:
    """Return the folders named on the command line as ``gaze_data``, ``eeg_data`` (None: find)."""
    folders = folders or {}
    return {'gaze_data': folders.get('real_gaze'), 'eeg_data': folders.get('real_eeg')}


def cpu_seconds() -> float:
    """CPU time of this process and of its finished child processes so far, s (user + system)."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def _minutes(seconds: float) -> str:
    """``m:ss``."""
    return f'{int(seconds // 60)}:{int(seconds % 60):02d}'


class _Heartbeat:
    """Print a line every :data:`HEARTBEAT_S` while a section runs (progress of a long one)."""

    def __init__(self, label: str, log: TextIO, period: float):
        self._label, self._log, self._period = label, log, period
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._beat, daemon=True)

    def __enter__(self) -> '_Heartbeat':
        self._started = time.perf_counter()
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join()

    def _beat(self) -> None:
        while not self._stop.wait(self._period):
            print(f'  ... {self._label} still running '
                  f'({_minutes(time.perf_counter() - self._started)})', file=self._log,
                  flush=True)


def run_benchmarks(names: Sequence[str], quick: bool = False, log: Optional[TextIO] = None,
                   mode: Optional[str] = None, data: Optional[Dict[str, str]] = None,
                   on_section: Optional[Callable[[str, Dict], None]] = None,
                   heartbeat_s: float = HEARTBEAT_S) -> Dict[str, Dict]:
    """
    Run benchmarks by name, saying on ``log`` which one runs, how far the run is and since when.

    :param quick: the smoke sizes (same as ``mode='quick'``).
    :param log: where progress goes (default: stderr).
    :param mode: one of :data:`MODES`; default ``'default'`` (``'quick'`` with ``quick``).
    :param data: recordings folders by kind (``'real_gaze'``, ``'real_eeg'``).
    :param on_section: called with ``(name, outcome)`` after each section (its table, the
        JSON file), so that results appear as they come.
    :returns: ``{'sections': {name: section}, 'skipped': {name: reason},
        'errors': {name: traceback text}, 'seconds': {name: wall time},
        'cpu_seconds': {name: CPU time of this process and the child processes it waited
        for, user + system: on a busy machine, what the section itself cost},
        'shortened': {name: what the run left out},
        'columns': {name: TABLE_COLUMNS or None},
        'formatters': {name: format_lines or None}}``.
    """
    log = log or sys.stderr
    mode = mode or ('quick' if quick else 'default')
    if mode not in MODES:
        raise ValueError(f'mode must be one of {MODES}, got {mode!r}')
    outcome: Dict[str, Dict] = {'sections': {}, 'skipped': {}, 'errors': {}, 'seconds': {},
                                'cpu_seconds': {}, 'shortened': {}, 'columns': {},
                                'formatters': {}}
    begun = time.perf_counter()
    for number, name in enumerate(names, 1):
        start, cpu_start = time.perf_counter(), cpu_seconds()
        where = f'[{number}/{len(names)} {_minutes(start - begun)}] {name}'
        reason = None
        try:
            module = load(name)
            folder, reason = data_folder(name, data or {})
            if name in NEEDS_BOTH:
                reason = module.unavailable(**_both(data))
            elif reason is None and folder is None:
                reason = getattr(module, 'unavailable', lambda: None)()
        except NotAvailable as missing:
            reason = str(missing)
        except Exception:  # report it and go on with the others
            outcome['errors'][name] = traceback.format_exc()
            print(f'{where}: cannot load\n{outcome["errors"][name]}', file=log)
            continue
        if reason:  # e.g. its recordings are not on this machine
            outcome['skipped'][name] = reason
            print(f'{where}: skipped ({reason})', file=log, flush=True)
            if on_section is not None:
                on_section(name, outcome)
            continue
        kwargs, shortened = run_arguments(name, mode, module)
        if folder is not None:
            kwargs['data'] = folder
        if name in NEEDS_BOTH:
            kwargs.update(_both(data))
        outcome['shortened'][name] = shortened
        print(f'{where}: running ({shortened or f"{mode} run, complete"}) ...', file=log,
              flush=True)
        try:
            outcome['columns'][name] = getattr(module, 'TABLE_COLUMNS', None)
            outcome['formatters'][name] = getattr(module, 'format_lines', None)
            with _Heartbeat(name, log, heartbeat_s):
                section = module.run(**kwargs)
            if isinstance(section, dict) and set(section) == {'skipped'}:   # it found no data
                why = section['skipped']
                outcome['skipped'][name] = str(why.get('reason', why) if isinstance(why, dict)
                                               else why)
            else:
                outcome['sections'][name] = section
        except Exception:  # a failing benchmark must not hide the others
            outcome['errors'][name] = traceback.format_exc()
            print(f'{name}: FAILED\n{outcome["errors"][name]}', file=log)
        outcome['seconds'][name] = round(time.perf_counter() - start, 2)
        outcome['cpu_seconds'][name] = round(cpu_seconds() - cpu_start, 2)
        print(f'{where}: done in {_minutes(outcome["seconds"][name])}, CPU '
              f'{_minutes(outcome["cpu_seconds"][name])} (run so far '
              f'{_minutes(time.perf_counter() - begun)}; load average '
              f'{os.getloadavg()[0]:.1f})', file=log, flush=True)
        if on_section is not None:
            on_section(name, outcome)
    return outcome


def _format_value(value) -> str:
    """Short human form of a table cell."""
    if isinstance(value, bool):
        return 'yes' if value else 'no'
    if isinstance(value, float):
        if math.isnan(value) or math.isinf(value):
            return str(value)
        if value != 0 and (abs(value) >= 1e4 or abs(value) < 1e-3):
            return f'{value:.3g}'
        return f'{value:.3f}' if abs(value) < 10 else f'{value:.1f}'
    if isinstance(value, (dict, list)):
        return json.dumps(value, separators=(',', ':'))
    return str(value)


def format_table(name: str, section, columns: Optional[Sequence[str]] = None) -> List[str]:
    """
    Lines of a table for one section: one row per key, one column per metric.

    :param columns: metrics to show, in order; default every metric found.
    A section that is not ``{row: {metric: value}}`` is printed as JSON.
    """
    if not isinstance(section, dict) or not section or \
            not all(isinstance(row, dict) for row in section.values()):
        return [f'{name}: {json.dumps(section)}']
    columns = list(columns or [])
    if not columns:
        for row in section.values():
            columns.extend(key for key in row if key not in columns)
    cells = [[name] + columns]
    cells += [[str(key)] + [_format_value(row.get(column, '')) for column in columns]
              for key, row in section.items()]
    widths = [max(len(line[i]) for line in cells) for i in range(len(cells[0]))]
    lines = ['  '.join(cell.rjust(width) for cell, width in zip(line, widths))
             for line in cells]
    lines.insert(1, '  '.join('-' * width for width in widths))
    return lines


def section_lines(name: str, section, columns: Optional[Sequence[str]] = None,
                  formatter: Optional[Callable[[Dict], List[str]]] = None) -> List[str]:
    """
    Lines of one section: the module's own ``format_lines`` when it has one.

    :param columns: for :func:`format_table`, without a formatter.
    :param formatter: the module's ``format_lines(section) -> list[str]``; if
        it fails, the failure is noted and :func:`format_table` prints the section.
    """
    if formatter is not None:
        try:
            return [f'{name}:'] + [str(line) for line in formatter(section)]
        except Exception as error:  # a broken table must not hide the results
            return [f'{name}: format_lines failed ({error!r}); generic table:'] + \
                format_table(name, section, columns)
    return format_table(name, section, columns)


def disagreements(sections: Dict[str, Dict]) -> List[str]:
    """Names ``section/row`` of the rows whose ``agrees`` is false."""
    return [f'{name}/{key}' for name, section in sections.items() if isinstance(section, dict)
            for key, row in section.items()
            if isinstance(row, dict) and row.get('agrees') is False]


def _existing_results(path: str) -> Dict:
    """Results already in ``path``, or {} when absent or unreadable."""
    try:
        with open(path, encoding='utf-8') as existing:
            results = json.load(existing)
    except (OSError, ValueError):
        return {}
    return results if isinstance(results, dict) else {}


def parse_args(argv: Optional[Sequence[str]] = None) -> argparse.Namespace:
    """Parse the command line."""
    parser = argparse.ArgumentParser(
        prog='python -m bench.run_all',
        description='Run the eye_bci_ros2 benchmarks (about 10 minutes on 2 cores; --full: the '
                    'complete tables); print each section as it finishes and write JSON '
                    'results.')
    size = parser.add_mutually_exclusive_group()
    size.add_argument('--full', action='store_true',
                      help='the complete tables: every trial, round and size (tens of minutes)')
    size.add_argument('--quick', action='store_true',
                      help="each section's smoke sizes (rough numbers, for checking the "
                           'plumbing; not shorter than the default run everywhere)')
    parser.add_argument('--only', action='append', default=[], metavar='NAME',
                        help=f'run only these benchmarks (repeat or comma-separate); '
                             f'one of: {", ".join(REGISTRY)}')
    parser.add_argument('--output', default=DEFAULT_OUTPUT, metavar='PATH',
                        help='JSON file to write (default: %(default)s)')
    parser.add_argument('--gaze-data', metavar='DIR',
                        help='folder of real gaze recordings (default: ../shared/data/'
                             'real_gaze or $EYE_BCI_DATA/real_gaze; sections '
                             f'{", ".join(n for n, k in NEEDS_DATA.items() if k == "real_gaze")}, '
                             f'{", ".join(NEEDS_BOTH)})')
    parser.add_argument('--eeg-data', metavar='DIR',
                        help='folder of real EEG recordings (default: $EYE_BCI_REAL_EEG or '
                             f'../shared/data/real_eeg; sections ssvep_real, '
                             f'{", ".join(NEEDS_BOTH)})')
    args = parser.parse_args(argv)
    only = [name.strip() for item in args.only for name in item.split(',') if name.strip()]
    unknown = [name for name in only if name not in REGISTRY]
    if unknown:
        parser.error(f'unknown benchmark {", ".join(unknown)}; choose from '
                     f'{", ".join(REGISTRY)}')
    args.only = only
    args.mode = 'full' if args.full else 'quick' if args.quick else 'default'
    return args


def _write(path: str, results: Dict) -> None:
    """Write the results (after every section: an interrupted run keeps what finished)."""
    with open(path, 'w', encoding='utf-8') as output:
        json.dump(results, output, indent=2, sort_keys=False)
        output.write('\n')


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Run the benchmarks, print each table as it comes, write the JSON; 1 when one failed."""
    quiet_liblsl()     # before the first LSL stream: liblsl quiet, as every executable
    args = parse_args(argv)
    names = args.only or list(REGISTRY)
    results = _existing_results(args.output) if args.only else {}
    results['machine'] = machine_info()
    machine = results['machine']
    print(f"machine: {machine['processor']}, {machine['cpus_available']} of "
          f"{machine['cpu_count']} CPUs, Python {machine['python']}, numpy {machine['numpy']}; "
          f'{args.mode} run of {len(names)} section(s)', flush=True)
    run = {
        'command': ' '.join(['python -m bench.run_all'] + list(
            sys.argv[1:] if argv is None else argv)),
        'mode': args.mode, 'quick': args.mode == 'quick', 'benchmarks': names,
        'seconds': {}, 'cpu_seconds': {}, 'load_average': [], 'shortened': {}, 'skipped': {},
        'errors': {},
    }
    results['run'] = run

    def finished(name: str, outcome: Dict) -> None:
        if name in outcome['sections']:
            results[name] = outcome['sections'][name]
            print()
            if outcome['shortened'].get(name):
                print(f'{name} ({args.mode} run: {outcome["shortened"][name]}; --full for the '
                      'complete table)')
            print('\n'.join(section_lines(name, results[name], outcome['columns'].get(name),
                                          outcome['formatters'].get(name))), flush=True)
        else:
            results.pop(name, None)  # never leave a stale section next to fresh ones
            if name in outcome['skipped']:
                print(f'\n{name}: skipped ({outcome["skipped"][name]})', flush=True)
            else:
                print(f'\n{name}: FAILED (traceback on stderr)', flush=True)
        run['load_average'].append(round(os.getloadavg()[0], 2))   # the machine was busy?
        run.update(seconds=outcome['seconds'], cpu_seconds=outcome['cpu_seconds'],
                   skipped=outcome['skipped'],
                   shortened={k: v for k, v in outcome['shortened'].items() if v},
                   errors={key: text.strip().splitlines()[-1]
                           for key, text in outcome['errors'].items()})
        run['finished'] = datetime.datetime.now(datetime.timezone.utc).isoformat(
            timespec='seconds')
        _write(args.output, results)

    outcome = run_benchmarks(names, mode=args.mode, on_section=finished,
                             data={'real_gaze': args.gaze_data, 'real_eeg': args.eeg_data})
    for name in outcome['errors']:
        if name not in outcome['seconds']:   # could not even be loaded
            finished(name, outcome)
    run['total_seconds'] = round(sum(outcome['seconds'].values()), 1)
    _write(args.output, results)
    wrong = disagreements(outcome['sections'])
    print(f"\n{args.mode} run: {len(outcome['sections'])} section(s) in "
          f"{_minutes(run['total_seconds'])}, {len(outcome['skipped'])} skipped, "
          f"{len(outcome['errors'])} failed")
    for name, seconds in outcome['seconds'].items():
        print(f'  {name:<16} {_minutes(seconds):>6} (CPU {_minutes(outcome["cpu_seconds"][name])})'
              f'  {outcome["shortened"].get(name, "")}')
    for name, reason in outcome['skipped'].items():
        print(f'  {name:<16} skipped: {reason}')
    if wrong:
        print(f'\nFAST PATH AND REFERENCE DISAGREE: {", ".join(wrong)}')
    print(f'wrote {args.output}')
    return 1 if outcome['errors'] or wrong else 0


if __name__ == '__main__':
    sys.exit(main())
