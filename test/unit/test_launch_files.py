"""
The launch files name only what the package installs, without running ``launch``.

``launch`` is not on PyPI (test/system/test_ros2_cli.py runs ``ros2
launch`` when the real command line is at hand).  The files are read with
``ast``: every ``Node(package='eye_bci_ros2', executable=...)`` must be a
console script of setup.py, every file reached through
``FindPackageShare('eye_bci_ros2')`` must be installed by setup.py's
``data_files`` (evaluated by running setup.py with ``setuptools.setup``
captured), every ``LaunchConfiguration`` must be declared in its file, and
the files may import only launch, launch_ros, ament_index_python, os and the
package's boolean-argument check (every boolean argument is declared through
it, so ``rviz:=maybe`` is refused).
"""

import ast
import os
from pathlib import Path
import runpy
from typing import Dict, List, Set
from unittest import mock

import pytest

from eye_bci_ros2.ros.launch_arguments import FALSE_VALUES, parse_boolean, TRUE_VALUES

REPO = Path(__file__).resolve().parents[2]
PACKAGE = 'eye_bci_ros2'
LAUNCH_FILES = sorted((REPO / 'launch').glob('*.launch.py'))
ALLOWED_IMPORTS = ('launch', 'launch_ros', 'ament_index_python', 'os')
#: The package's launch helper (its booleans); no other module of the package.
HELPER = 'eye_bci_ros2.ros.launch_arguments'
#: Executables of other packages a launch file may start: package -> executables.
EXTERNAL_EXECUTABLES = {'rviz2': {'rviz2'}}
#: Files added apart (config/eye_bci.rviz): checked once they exist.
PENDING_SOURCES = {'share/eye_bci_ros2/config/eye_bci.rviz': REPO / 'config' / 'eye_bci.rviz'}


def setup_arguments() -> dict:
    """Run setup.py (in the repository) with setuptools.setup captured."""
    with mock.patch('setuptools.setup') as setup:
        cwd = os.getcwd()
        os.chdir(REPO)
        try:
            runpy.run_path(str(REPO / 'setup.py'))
        finally:
            os.chdir(cwd)
    return setup.call_args.kwargs


def installed_files() -> Set[str]:
    """Return every path data_files installs, relative to the install prefix."""
    files = set()
    for destination, sources in setup_arguments()['data_files']:
        files |= {f'{destination}/{os.path.basename(source)}' for source in sources}
    return files


def console_scripts() -> Set[str]:
    """Return the names of setup.py's console scripts."""
    entries = setup_arguments()['entry_points']['console_scripts']
    return {entry.split('=', 1)[0].strip() for entry in entries}


def tree(path: Path) -> ast.Module:
    return ast.parse(path.read_text(), filename=str(path))


def calls(module: ast.Module, name: str) -> List[ast.Call]:
    """Return the calls of a function or class called ``name`` (plain or attribute)."""
    found = []
    for node in ast.walk(module):
        if isinstance(node, ast.Call):
            callee = node.func
            callee_name = callee.id if isinstance(callee, ast.Name) else \
                callee.attr if isinstance(callee, ast.Attribute) else None
            if callee_name == name:
                found.append(node)
    return found


def keywords(call: ast.Call) -> Dict[str, ast.AST]:
    return {keyword.arg: keyword.value for keyword in call.keywords}


def literal(node: ast.AST, where: str):
    """Return a constant's value, or fail naming where the non-literal was."""
    assert isinstance(node, ast.Constant), f'{where}: expected a literal, got {ast.dump(node)}'
    return node.value


def module_constants(module: ast.Module) -> Dict[str, object]:
    """Return the module-level NAME = 'literal' assignments."""
    constants = {}
    for statement in module.body:
        if isinstance(statement, ast.Assign) and isinstance(statement.value, ast.Constant):
            for target in statement.targets:
                if isinstance(target, ast.Name):
                    constants[target.id] = statement.value.value
    return constants


def value(node: ast.AST, constants: Dict[str, object], where: str):
    """Return a literal or a module constant's value."""
    if isinstance(node, ast.Name) and node.id in constants:
        return constants[node.id]
    return literal(node, where)


def share_paths(module: ast.Module, constants) -> List[str]:
    """Return the install paths of PathJoinSubstitution([FindPackageShare(pkg), 'a', 'b'])."""
    paths = []
    for call in calls(module, 'PathJoinSubstitution'):
        parts = call.args[0]
        assert isinstance(parts, ast.List), 'PathJoinSubstitution takes a literal list here'
        first = parts.elts[0]
        if isinstance(first, ast.Call) and getattr(first.func, 'id', '') == 'FindPackageShare':
            package = value(first.args[0], constants, 'FindPackageShare')
            rest = [value(part, constants, 'PathJoinSubstitution') for part in parts.elts[1:]]
            paths.append('/'.join(['share', package] + rest))
    return paths


def booleans(module: ast.Module) -> Dict[str, bool]:
    """Return the arguments declared by ``boolean_arguments((name, default, text), ...)``."""
    found = {}
    for call in calls(module, 'boolean_arguments'):
        for argument in call.args:
            assert isinstance(argument, ast.Tuple), 'boolean_arguments takes literal tuples'
            name, default = (literal(part, 'boolean argument') for part in argument.elts[:2])
            found[name] = default
    return found


@pytest.fixture(scope='module')
def installed():
    return installed_files()


def test_the_two_launch_files_exist_and_are_installed(installed):
    names = [path.name for path in LAUNCH_FILES]
    assert names == ['experiment.launch.py', 'pipeline.launch.py']
    for name in names:
        assert f'share/{PACKAGE}/launch/{name}' in installed


@pytest.mark.parametrize('path', LAUNCH_FILES, ids=lambda path: path.name)
def test_only_launch_launch_ros_and_ament_index_are_imported(path):
    module = tree(path)
    imported = []
    for node in ast.walk(module):
        if isinstance(node, ast.Import):
            imported += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            imported.append(node.module)
    assert imported
    for name in imported:
        assert name.split('.')[0] in ALLOWED_IMPORTS or name == HELPER, \
            f'{path.name} imports {name}'
    assert any(isinstance(node, ast.FunctionDef) and node.name == 'generate_launch_description'
               for node in module.body)


@pytest.mark.parametrize('path', LAUNCH_FILES, ids=lambda path: path.name)
def test_every_executable_is_a_console_script(path):
    module = tree(path)
    constants = module_constants(module)
    scripts = console_scripts()
    nodes = calls(module, 'Node')
    assert nodes, f'{path.name} starts no node'
    for call in nodes:
        arguments = keywords(call)
        package = value(arguments['package'], constants, 'Node package')
        executable = value(arguments['executable'], constants, 'Node executable')
        if package == PACKAGE:
            assert executable in scripts, f'{path.name}: {executable} is not a console script'
        else:
            assert executable in EXTERNAL_EXECUTABLES.get(package, ()), \
                f'{path.name}: {package}/{executable} is not an expected external executable'


@pytest.mark.parametrize('path', LAUNCH_FILES, ids=lambda path: path.name)
def test_every_package_file_named_is_installed(path, installed):
    module = tree(path)
    paths = share_paths(module, module_constants(module))
    assert paths, f'{path.name} names no installed file'
    for share_path in paths:
        pending = PENDING_SOURCES.get(share_path)
        if pending is not None and not pending.exists():
            continue    # not in this tree yet; its data_files glob is checked below
        assert share_path in installed, f'{path.name} names {share_path}, not installed'


def test_the_rviz_file_glob_is_in_data_files():
    sources = [source for destination, found in setup_arguments()['data_files']
               if destination == f'share/{PACKAGE}/config' for source in found]
    assert 'config/eye_bci.yaml' in sources
    # config/eye_bci.rviz is installed by the same entry once it exists (glob config/*.rviz).
    setup_text = (REPO / 'setup.py').read_text()
    assert "glob('config/*.rviz')" in setup_text


@pytest.mark.parametrize('path', LAUNCH_FILES, ids=lambda path: path.name)
def test_every_launch_configuration_is_declared(path):
    module = tree(path)
    declared = {literal(call.args[0], 'DeclareLaunchArgument')
                for call in calls(module, 'DeclareLaunchArgument')} | set(booleans(module))
    used = {literal(call.args[0], 'LaunchConfiguration')
            for call in calls(module, 'LaunchConfiguration')}
    used |= {literal(call.args[1], 'is_true') for call in calls(module, 'is_true')}
    assert used and used <= declared, f'{path.name}: undeclared {sorted(used - declared)}'
    for call in calls(module, 'DeclareLaunchArgument'):
        assert 'description' in keywords(call), f'{path.name}: argument without description'


def test_both_files_take_the_tracker_profile_and_params_file_and_the_experiment_the_rviz_file():
    arguments = {}
    for path in LAUNCH_FILES:
        module = tree(path)
        arguments[path.name] = {
            literal(call.args[0], 'DeclareLaunchArgument'): keywords(call)
            for call in calls(module, 'DeclareLaunchArgument')}
    for name, declared in arguments.items():
        assert {'params_file', 'profile', 'rviz_config'} <= set(declared), name
    experiment = tree(REPO / 'launch' / 'experiment.launch.py')
    constants = module_constants(experiment)
    assert f'share/{PACKAGE}/config/eye_bci.rviz' in share_paths(experiment, constants)
    assert f'share/{PACKAGE}/launch/pipeline.launch.py' in share_paths(experiment, constants)
    # The pipeline's profile default is empty: the params file decides unless profile:= is given.
    pipeline_profile = arguments['pipeline.launch.py']['profile']['default_value']
    assert literal(pipeline_profile, 'profile default') == ''


def test_pipeline_starts_the_pipeline_nodes_and_the_experiment_adds_menu_and_rviz():
    def executables(name):
        module = tree(REPO / 'launch' / name)
        return sorted(literal(keywords(call)['executable'], 'executable')
                      for call in calls(module, 'Node'))
    assert executables('pipeline.launch.py') == [
        'camera_tracker', 'choice_arbiter', 'lsl_gaze_bridge', 'marker_projector',
        'session_markers']
    assert executables('experiment.launch.py') == ['choice_menu', 'rviz2', 'sim_robot']


@pytest.mark.parametrize('path', LAUNCH_FILES, ids=lambda path: path.name)
def test_every_boolean_argument_is_declared_with_its_check(path):
    """A boolean declared plainly would read ``rviz:=maybe`` as false without a word."""
    module = tree(path)
    for call in calls(module, 'DeclareLaunchArgument'):
        default = keywords(call).get('default_value')
        if isinstance(default, ast.Constant) and isinstance(default.value, str):
            assert default.value.lower() not in TRUE_VALUES + FALSE_VALUES, \
                f'{path.name}: {literal(call.args[0], "argument")} is a boolean: declare it ' \
                'with boolean_arguments (it refuses what is not one)'
    assert "LaunchConfiguration('rviz')" not in path.read_text()


def test_the_experiment_declares_rviz_as_a_checked_boolean_before_anything_starts():
    module = tree(REPO / 'launch' / 'experiment.launch.py')
    assert booleans(module) == {'rviz': True}
    listed = [ast.unparse(element) for element in calls(module, 'LaunchDescription')[0]
              .args[0].elts]
    check = next(i for i, text in enumerate(listed) if 'boolean_arguments' in text)
    starts = [i for i, text in enumerate(listed)
              if text.startswith(('IncludeLaunchDescription', 'OpaqueFunction(function=_menu',
                                  'OpaqueFunction(function=_robot'))]
    assert starts and check < min(starts)


@pytest.mark.parametrize('text, expected', [('true', True), ('True', True), ('1', True),
                                            ('false', False), ('FALSE', False), ('0', False)])
def test_boolean_arguments_read_launch_s_own_values(text, expected):
    assert parse_boolean('rviz', text) is expected


@pytest.mark.parametrize('text', ['maybe', '', 'yes!', 'treu', '2'])
def test_anything_else_is_refused_with_the_accepted_values(text):
    with pytest.raises(ValueError) as refused:
        parse_boolean('rviz', text)
    assert str(refused.value) == (f"rviz:='{text}' is not a boolean (accepted: true, 1, false, "
                                  '0; any case): nothing started')


def launch_function(name, values):
    """
    Build one function of experiment.launch.py with its module constants, without ``launch``.

    ``launch`` is not on PyPI: ``LaunchConfiguration`` is replaced by a stand-in
    that returns the argument's value from ``values``, as launch's ``perform`` does.
    """
    module = tree(REPO / 'launch' / 'experiment.launch.py')
    keep = [node for node in module.body
            if isinstance(node, ast.Assign) or (isinstance(node, ast.FunctionDef)
                                                and node.name == name)]
    namespace = {'LaunchConfiguration': lambda argument: mock.Mock(
        perform=lambda context: values[argument])}
    exec(compile(ast.Module(body=keep, type_ignores=[]), 'experiment.launch.py', 'exec'),
         namespace)
    return namespace[name]


def test_the_robot_argument_takes_sim_or_none_and_refuses_anything_else():
    arguments = {literal(call.args[0], 'DeclareLaunchArgument'): keywords(call)
                 for call in calls(tree(REPO / 'launch' / 'experiment.launch.py'),
                                   'DeclareLaunchArgument')}
    assert 'robot' in arguments
    for value in ('sim', 'none'):
        assert launch_function('_check_robot', {'robot': value})(None) == []
    for value in ('gazebo', 'Sim', ''):
        with pytest.raises(RuntimeError, match=f"robot:='{value}' is not one of sim, none"):
            launch_function('_check_robot', {'robot': value})(None)
