"""
Single homes that a test enforces: topic names and the node registry.

* Every publisher and subscription of the package and the benchmarks names
  its topic by a constant of ``eye_bci_ros2/ros/topics.py`` (or a
  parameter), never by a string literal: the topic contract has one home.
  Tests may spell names out, to check that contract from the outside.
* Every module that declares ROS parameters runs a node of the registry
  (``eye_bci_ros2/ros/registry.py``), whose executables are what setup.py
  installs, so the parameter tables, the defaults file and the parameter
  fault suite reach every parameter.

Both read the source (``ast``), so they need neither ROS nor a build.
"""

import ast
from importlib import metadata
from pathlib import Path
import runpy
from typing import Iterator, Tuple

from paths import REPO
import pytest

#: Calls whose topic is their second positional argument or ``topic=``.
TOPIC_CALLS = ('create_publisher', 'create_subscription')
#: Folders whose code must name topics by constant.
CHECKED = ('eye_bci_ros2', 'bench')

REGISTRY = runpy.run_path(str(REPO / 'eye_bci_ros2' / 'ros' / 'registry.py'))


def sources(*folders: str) -> Iterator[Path]:
    """Yield the Python files under the repository's ``folders``."""
    for folder in folders:
        yield from sorted((REPO / folder).rglob('*.py'))


def topic_literals(path: Path) -> Iterator[Tuple[int, str]]:
    """Yield (line, source) of each topic given as a string literal in ``path``."""
    for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'), str(path))):
        if not isinstance(node, ast.Call) or not isinstance(node.func, ast.Attribute) or \
                node.func.attr not in TOPIC_CALLS:
            continue
        topic = node.args[1] if len(node.args) > 1 else next(
            (k.value for k in node.keywords if k.arg == 'topic'), None)
        if isinstance(topic, (ast.Constant, ast.JoinedStr)):
            yield node.lineno, ast.unparse(topic)


def test_topics_are_named_by_their_constants():
    found = [f'{path.relative_to(REPO)}:{line}: {text}' for path in sources(*CHECKED)
             for line, text in topic_literals(path)]
    assert not found, ('topic literals in publisher/subscription calls; use (or add) the '
                       'constant in eye_bci_ros2/ros/topics.py:\n' + '\n'.join(found))


def test_the_check_finds_a_literal(tmp_path):
    sample = tmp_path / 'sample.py'
    sample.write_text('node.create_publisher(String, "choice", 10)\n'
                      'node.create_subscription(String, CHOICE_TOPIC, cb, 10)\n'
                      'node.create_subscription(msg_type=String, topic=f"{ns}/x", '
                      'callback=cb, qos_profile=10)\n')
    assert list(topic_literals(sample)) == [(1, "'choice'"), (3, "f'{ns}/x'")]


def declares_parameters(path: Path) -> bool:
    """Tell whether a module calls declare_parameters or declare_parameter."""
    for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'), str(path))):
        if isinstance(node, ast.Call):
            name = node.func.attr if isinstance(node.func, ast.Attribute) else \
                getattr(node.func, 'id', '')
            if name in ('declare_parameters', 'declare_parameter'):
                return True
    return False


def module_path(module: str) -> Path:
    """Return the file of a dotted module name of the repository (a package's ``__init__``)."""
    package = REPO / module.replace('.', '/') / '__init__.py'
    return package if package.exists() else REPO / (module.replace('.', '/') + '.py')


def module_name(path: Path) -> str:
    """Return the dotted module name of a file of the repository (a package for ``__init__``)."""
    parts = path.relative_to(REPO).with_suffix('').parts
    return '.'.join(parts[:-1] if parts[-1] == '__init__' else parts)


def test_every_module_with_parameters_runs_a_registered_node():
    registered = {entry.module for entry in REGISTRY['parameter_nodes']()}
    helpers = {'eye_bci_ros2.ros.parameters'}     # the declaration helper itself
    declaring = {module_name(path) for path in sources('eye_bci_ros2')
                 if declares_parameters(path)}
    assert declaring - helpers <= registered, \
        f'declare parameters but are not in ros/registry.py: {declaring - helpers - registered}'


def test_every_registered_executable_exists():
    for entry in REGISTRY['EXECUTABLES']:
        source = module_path(entry.module).read_text(encoding='utf-8')
        assert '\ndef main(' in source, f'{entry.module} has no main()'
        if entry.node_class:
            assert f'\nclass {entry.node_class}(' in source, \
                f'{entry.module} has no class {entry.node_class}'
    names = [entry.name for entry in REGISTRY['EXECUTABLES']]
    assert len(names) == len(set(names)), 'an executable is registered twice'


def test_the_installed_executables_are_the_registry():
    try:
        scripts = metadata.distribution('eye_bci_ros2').entry_points
    except metadata.PackageNotFoundError:
        pytest.skip('eye_bci_ros2 is not installed (make .venv/.installed)')
    installed = {f'{e.name} = {e.value}' for e in scripts if e.group == 'console_scripts'}
    assert installed == set(REGISTRY['console_scripts']()), \
        'setup.py installs other executables than ros/registry.py lists (reinstall?)'
