"""
Run the benchmarks, print a table and write ``bench_results.json``.

``make bench`` runs ``python -m bench.run_all``.  Every benchmark is a module
with ``run(quick: bool = False) -> dict`` returning its section of the results
(``{row: {metric: value}}``, e.g. ``{'1000': {'ms': 1.2}}``); :data:`REGISTRY`
names them.  A module that does not exist yet (``bench.latency``,
``bench.decision``), or whose ``unavailable() -> str`` gives a reason (its
recordings are absent), is reported as skipped; any other failure is recorded in the
JSON and makes the exit status 1, after the other benchmarks have run, as does a
row whose ``agrees`` is false (fast path and reference disagree).  A module may
name the metrics its table shows in ``TABLE_COLUMNS`` (default: all), or print
its own table: ``format_lines(section) -> list[str]`` (used when present, e.g.
for a nested section such as ``bench.decision``'s).

Usage::

    python -m bench.run_all [--quick] [--only NAME[,NAME]] [--output PATH]

With ``--only`` the sections already in the output file are kept and only the
named ones are replaced.
"""

import argparse
import datetime
import importlib
import json
import math
import os
import sys
import time
import traceback
from typing import Callable, Dict, List, Optional, Sequence

from bench.timing import machine_info

#: Benchmark name -> module providing ``run(quick=False) -> dict``, in run order.
REGISTRY: Dict[str, str] = {
    'projection': 'bench.projection',
    'arbitration': 'bench.arbitration',
    'latency': 'bench.latency',
    'gaze_rate': 'bench.gaze_rate',
    'real_gaze': 'bench.real_gaze',
    'decision': 'bench.decision',
    'tolerance': 'bench.tolerance',
    'validation': 'bench.validation',
    'correction_fit': 'bench.correction_fit',
    'calibration': 'bench.calibration_protocol',
    'ssvep': 'bench.ssvep',
    'ssvep_real': 'bench.ssvep_real',
}

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


def run_benchmarks(names: Sequence[str], quick: bool = False,
                   log=sys.stderr) -> Dict[str, Dict]:
    """
    Run benchmarks by name.

    :returns: ``{'sections': {name: section}, 'skipped': {name: reason},
        'errors': {name: traceback text}, 'seconds': {name: wall time},
        'columns': {name: TABLE_COLUMNS or None},
        'formatters': {name: format_lines or None}}``.
    """
    outcome: Dict[str, Dict] = {'sections': {}, 'skipped': {}, 'errors': {}, 'seconds': {},
                                'columns': {}, 'formatters': {}}
    for name in names:
        start = time.perf_counter()
        try:
            module = load(name)
        except NotAvailable as reason:
            outcome['skipped'][name] = str(reason)
            print(f'{name}: skipped ({reason})', file=log)
            continue
        except Exception:  # report it and go on with the others
            outcome['errors'][name] = traceback.format_exc()
            print(f'{name}: cannot load\n{outcome["errors"][name]}', file=log)
            continue
        reason = getattr(module, 'unavailable', lambda: None)()
        if reason:  # e.g. its recordings are not on this machine
            outcome['skipped'][name] = reason
            print(f'{name}: skipped ({reason})', file=log)
            continue
        print(f'{name}: running{" (quick)" if quick else ""} ...', file=log, flush=True)
        try:
            outcome['columns'][name] = getattr(module, 'TABLE_COLUMNS', None)
            outcome['formatters'][name] = getattr(module, 'format_lines', None)
            outcome['sections'][name] = module.run(quick=quick)
        except Exception:  # a failing benchmark must not hide the others
            outcome['errors'][name] = traceback.format_exc()
            print(f'{name}: FAILED\n{outcome["errors"][name]}', file=log)
        outcome['seconds'][name] = round(time.perf_counter() - start, 2)
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
        description='Run the eye_bci_ros2 benchmarks; print a table and write JSON results.')
    parser.add_argument('--quick', action='store_true',
                        help='small sizes and few repeats (seconds; numbers are rough)')
    parser.add_argument('--only', action='append', default=[], metavar='NAME',
                        help=f'run only these benchmarks (repeat or comma-separate); '
                             f'one of: {", ".join(REGISTRY)}')
    parser.add_argument('--output', default=DEFAULT_OUTPUT, metavar='PATH',
                        help='JSON file to write (default: %(default)s)')
    args = parser.parse_args(argv)
    only = [name.strip() for item in args.only for name in item.split(',') if name.strip()]
    unknown = [name for name in only if name not in REGISTRY]
    if unknown:
        parser.error(f'unknown benchmark {", ".join(unknown)}; choose from '
                     f'{", ".join(REGISTRY)}')
    args.only = only
    return args


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Run the benchmarks, print the tables, write the JSON; 1 when one failed."""
    args = parse_args(argv)
    names = args.only or list(REGISTRY)
    outcome = run_benchmarks(names, quick=args.quick)

    results = _existing_results(args.output) if args.only else {}
    results.update(outcome['sections'])
    for name in list(outcome['skipped']) + list(outcome['errors']):
        results.pop(name, None)  # never leave a stale section next to fresh ones
    results['machine'] = machine_info()
    results['run'] = {
        'command': ' '.join(['python -m bench.run_all'] + list(
            sys.argv[1:] if argv is None else argv)),
        'quick': args.quick,
        'benchmarks': names,
        'finished': datetime.datetime.now(datetime.timezone.utc).isoformat(timespec='seconds'),
        'seconds': outcome['seconds'],
        'skipped': outcome['skipped'],
        'errors': {name: text.strip().splitlines()[-1] for name, text in
                   outcome['errors'].items()},
    }
    with open(args.output, 'w', encoding='utf-8') as output:
        json.dump(results, output, indent=2, sort_keys=False)
        output.write('\n')

    machine = results['machine']
    print(f"machine: {machine['processor']}, {machine['cpus_available']} of "
          f"{machine['cpu_count']} CPUs, Python {machine['python']}, numpy {machine['numpy']}")
    for name in names:
        if name in outcome['sections']:
            print()
            table = section_lines(name, outcome['sections'][name], outcome['columns'].get(name),
                                  outcome['formatters'].get(name))
            print('\n'.join(table))
    for name, reason in outcome['skipped'].items():
        print(f'\n{name}: skipped ({reason})')
    for name in outcome['errors']:
        print(f'\n{name}: FAILED (traceback above)')
    wrong = disagreements(outcome['sections'])
    if wrong:
        print(f'\nFAST PATH AND REFERENCE DISAGREE: {", ".join(wrong)}')
    print(f'\nwrote {args.output}')
    return 1 if outcome['errors'] or wrong else 0


if __name__ == '__main__':
    sys.exit(main())
