"""
Count the bad inputs and faults the test suite tries (a pytest plugin).

Load it from ``test/conftest.py`` with ``pytest_plugins = ['fault_counter']``.
Every fault case registers itself with the ``fault`` fixture::

    def test_nan_gaze(graph, fault):
        with fault('gaze', 'NaN sample on gaze'):
            ...  # inject the fault, then assert alive / state kept / logged

A case is *handled* when its block finishes; it is *not handled* when its
block raises, or when its test fails outside every block (a final check that
covers them all); a *known bug* when the test is an expected failure
(``xfail``), and *skipped* with its test.  At the end
of the session the terminal summary says, e.g.::

    bad inputs and faults tried: 212 (gaze 14, camera 9, markers 16, parameters 160,
    calibration 13), all handled

(``-v`` lists every case).
"""

import contextlib
from dataclasses import dataclass
from typing import Dict, Iterator, List

import pytest

#: Fault categories, in the order the summary lists them.
CATEGORIES = ('gaze', 'camera', 'markers', 'parameters', 'calibration')

#: Outcomes of a case.
HANDLED, NOT_HANDLED, KNOWN_BUG, SKIPPED, RUNNING = (
    'handled', 'not handled', 'known bug', 'skipped', 'running')

_CASES = pytest.StashKey[List['FaultCase']]()


@dataclass
class FaultCase:
    """One bad input or fault tried by one test."""

    category: str
    name: str
    test: str
    outcome: str = RUNNING
    #: What the test measured, shown with ``-v`` (e.g. how many samples got through).
    note: str = ''


class FaultRecorder:
    """The ``fault`` fixture: ``with fault(category, name): ...`` registers a case."""

    def __init__(self, cases: List[FaultCase], test: str):
        """Record into ``cases`` on behalf of the test with node id ``test``."""
        self._cases = cases
        self._test = test

    @contextlib.contextmanager
    def __call__(self, category: str, name: str) -> Iterator[FaultCase]:
        """
        Register a fault case; it is handled if the block (and its test) passes.

        :param category: one of :data:`CATEGORIES`.
        :param name: what was tried, e.g. ``'NaN sample on gaze'``.
        """
        if category not in CATEGORIES:
            raise ValueError(f"unknown fault category '{category}': use one of "
                             f"{', '.join(CATEGORIES)}")
        case = FaultCase(category, name, self._test)
        self._cases.append(case)
        try:
            yield case
        except BaseException:
            case.outcome = NOT_HANDLED
            raise
        case.outcome = HANDLED


def pytest_configure(config: pytest.Config) -> None:
    """Start an empty list of cases for the session."""
    config.stash[_CASES] = []


@pytest.fixture
def fault(request: pytest.FixtureRequest) -> FaultRecorder:
    """Register the fault cases of a test (see the module doc)."""
    return FaultRecorder(request.config.stash[_CASES], request.node.nodeid)


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo):
    """Settle the outcome of a test's cases from its report."""
    report = yield
    if report.when == 'call' or report.failed or report.skipped:
        cases = [case for case in item.config.stash.get(_CASES, []) if case.test == item.nodeid]
        # A failure outside every case's block (e.g. the final "still alive" check)
        # implicates all of them; one inside a block is that case's alone.
        blamed = report.failed and not any(case.outcome == NOT_HANDLED for case in cases)
        for case in cases:
            if hasattr(report, 'wasxfail') and report.skipped:
                case.outcome = KNOWN_BUG
            elif report.skipped:
                case.outcome = SKIPPED
            elif blamed or case.outcome == RUNNING:
                case.outcome = NOT_HANDLED
    return report


def _counts(cases: List[FaultCase]) -> Dict[str, int]:
    counts = dict.fromkeys(CATEGORIES, 0)
    for case in cases:
        counts[case.category] += 1
    return counts


def summary_line(cases: List[FaultCase]) -> str:
    """Return the one-line summary of the cases tried (skipped ones are not counted)."""
    tried = [case for case in cases if case.outcome != SKIPPED]
    per_category = ', '.join(f'{category} {count}'
                             for category, count in _counts(tried).items())
    bad = [case for case in tried if case.outcome in (NOT_HANDLED, RUNNING)]
    known = [case for case in tried if case.outcome == KNOWN_BUG]
    verdict = 'all handled' if not bad and not known else ', '.join(part for part in (
        f'{len(bad)} NOT handled' if bad else '',
        f'{len(known)} known bugs (xfail)' if known else '') if part)
    return f'bad inputs and faults tried: {len(tried)} ({per_category}), {verdict}'


def pytest_terminal_summary(terminalreporter, exitstatus: int, config: pytest.Config) -> None:
    """Print how many bad inputs and faults were tried and how they ended."""
    cases = config.stash.get(_CASES, [])
    if not cases:
        return
    terminalreporter.section('bad inputs and faults')
    if config.option.verbose > 0:
        for case in sorted(cases, key=lambda c: (CATEGORIES.index(c.category), c.test)):
            note = f' ({case.note})' if case.note else ''
            terminalreporter.write_line(
                f'{case.category:<12} {case.outcome:<12} {case.name}{note}  [{case.test}]')
    for case in cases:
        if case.outcome in (NOT_HANDLED, RUNNING, KNOWN_BUG):
            terminalreporter.write_line(f'{case.outcome.upper()}: {case.category}: '
                                        f'{case.name} [{case.test}]')
    line = summary_line(cases)
    bad = any(case.outcome in (NOT_HANDLED, RUNNING) for case in cases)
    terminalreporter.write_line(line, bold=True, red=bad, green=not bad)
