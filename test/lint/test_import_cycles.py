"""No two modules of the package import each other, directly or around a circle."""

import ast

from paths import REPO

PACKAGE = REPO / 'eye_bci_ros2'


def module_name(path):
    """Name the module a file of the package holds ('eye_bci_ros2.ros.topics')."""
    parts = list(path.relative_to(REPO).with_suffix('').parts)
    if parts[-1] == '__init__':
        parts.pop()
    return '.'.join(parts)


def imports_of(path, modules):
    """Name the package's modules a file imports anywhere (a function's imports count too)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'))):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            candidates = [node.module] + [f'{node.module}.{a.name}' for a in node.names]
        elif isinstance(node, ast.Import):
            candidates = [alias.name for alias in node.names]
        else:
            continue
        found.update(name for name in candidates if name in modules)
    return found


def import_graph():
    """Map each module of the package to the package's modules it imports."""
    paths = {module_name(path): path for path in PACKAGE.rglob('*.py')}
    return {name: imports_of(path, paths) - {name} for name, path in paths.items()}


def circles(graph):
    """Return the strongly connected groups of more than one module (Tarjan), sorted."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(name):
        index[name] = low[name] = len(index)
        stack.append(name)
        on_stack.add(name)
        for used in graph[name]:
            if used not in index:
                visit(used)
                low[name] = min(low[name], low[used])
            elif used in on_stack:
                low[name] = min(low[name], index[used])
        if low[name] == index[name]:
            group = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                group.append(member)
                if member == name:
                    break
            if len(group) > 1:
                found.append(sorted(group))

    for name in sorted(graph):
        if name not in index:
            visit(name)
    return sorted(found)


def test_no_module_imports_around_a_circle():
    assert circles(import_graph()) == []


def test_the_circle_check_finds_a_circle():
    # The check must see a circle, or the test above passes on nothing.
    graph = {'a': {'b'}, 'b': {'c'}, 'c': {'a'}, 'd': {'a'}}
    assert circles(graph) == [['a', 'b', 'c']]
    assert 'eye_bci_ros2.ros.topics' in import_graph()['eye_bci_ros2.nodes.choice_menu']
