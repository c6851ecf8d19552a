"""The core's subpackages depend on each other one way only (docs/DESIGN.md, "Layout")."""

import ast

from paths import REPO

#: Which core subpackages each may import (besides ``base``, which all may).  The adapters,
#: simulation, experiments and tools (nodes, sim, experiments, tools) may import any of them;
#: none of these may import those.
ALLOWED = {
    'base': set(),
    'projection': set(),
    'streams': set(),
    'decision': {'projection', 'ssvep'},
    'gaze': {'projection', 'streams', 'decision'},
    'task': {'projection', 'decision'},
    'ssvep': {'streams'},
    'recordings': {'projection', 'gaze'},
    'navigation': {'task'},
}
OUTER = ('ros', 'nodes', 'sim', 'experiments', 'tools')


def imported_subpackages(path):
    """Name the eye_bci_ros2 subpackages a module imports (top-level name after the package)."""
    tree = ast.parse(path.read_text(encoding='utf-8'))
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module]
        elif isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        else:
            continue
        for name in names:
            parts = name.split('.')
            if parts[0] == 'eye_bci_ros2' and len(parts) > 1:
                found.add(parts[1])
    return found


def test_every_core_module_is_in_a_named_subpackage():
    package = REPO / 'eye_bci_ros2'
    flat = sorted(p.name for p in package.glob('*.py') if p.name != '__init__.py')
    assert flat == [], f'modules outside a subpackage: {flat}'
    folders = {p.name for p in package.iterdir() if (p / '__init__.py').exists()}
    assert folders == set(ALLOWED) | set(OUTER), folders ^ (set(ALLOWED) | set(OUTER))


def test_core_dependencies_point_one_way():
    wrong = []
    for layer, allowed in ALLOWED.items():
        for path in sorted((REPO / 'eye_bci_ros2' / layer).rglob('*.py')):
            for used in imported_subpackages(path) - allowed - {layer, 'base'}:
                wrong.append(f'{path.relative_to(REPO)} imports eye_bci_ros2.{used}')
    assert wrong == [], '\n'.join(wrong)


def test_the_layer_check_sees_imports():
    # The check itself must find an import, or the test above passes on nothing.
    assert 'projection' in imported_subpackages(REPO / 'eye_bci_ros2' / 'decision' / 'regions.py')
