"""
The one list of the package's executables and the nodes they run.

Everything that needs the list reads it from here: ``setup.py``'s
``console_scripts`` (:func:`console_scripts`), ``eye_bci``'s composed
pipeline (:func:`pipeline`, :func:`menu`), ``tools/describe``'s parameter
tables and ``config/eye_bci.yaml`` (:func:`parameter_nodes`), and the
parameter fault suite (``test/faults/test_faults_parameters.py``), which
therefore covers every parameter of every executable.  A test
(``test/lint/test_registry.py``) checks that every module declaring ROS
parameters is registered here.

Adding a node: one :class:`Executable` row below (its module has ``main()``
and the node class), its own module and test, and a good change for it in
the fault suite's ``GOOD_CHANGE``.

Pure standard library on purpose: ``setup.py`` loads this file by path at
build time, before the package (or rclpy) can be imported.
"""

import importlib.util
import os
from typing import NamedTuple, Tuple

#: Groups of executables.
PIPELINE = 'pipeline'   # composed by ``eye_bci``, in the order below
MENU = 'menu'           # the original experiment's menu (``eye_bci --with-menu``)
NODE = 'node'           # a node of its own
COMPOSITION = 'composition'   # several nodes in one process
SIM = 'sim'             # stand-ins for hardware and RViz
TOOL = 'tool'           # commands that run and end


class Executable(NamedTuple):
    """
    One ``ros2 run eye_bci_ros2 <name>`` executable.

    :ivar name: the executable's name; for a node, also its default node name.
    :ivar module: the module whose ``main()`` it runs.
    :ivar node_class: the class (in ``module``) of the one rclpy node it runs
        with declared parameters; '' when it runs none of its own (a
        composition, an LSL stand-in, a tool).
    :ivar group: :data:`PIPELINE`, :data:`MENU`, :data:`NODE`,
        :data:`COMPOSITION`, :data:`SIM` or :data:`TOOL`.
    :ivar requires: what creating the node needs beyond the package:
        :data:`DISPLAY` (it opens a window) or a Python module built apart
        (an RViz plugin's messages); '' = nothing.  Such a node's parameters
        are described from its module's ``PARAMETERS``, and its fault tests
        skip, saying why, where it is missing (:func:`missing`).
    """

    name: str
    module: str
    node_class: str = ''
    group: str = NODE
    requires: str = ''


#: :attr:`Executable.requires` of a node that opens a window.
DISPLAY = 'display'

_NODES = 'eye_bci_ros2.nodes.'

#: Every executable, in the order of the parameter tables and the defaults file.
EXECUTABLES: Tuple[Executable, ...] = (
    Executable('lsl_gaze_bridge', _NODES + 'lsl_gaze_bridge', 'LslGazeBridge', PIPELINE),
    Executable('camera_tracker', _NODES + 'camera_tracker', 'CameraTracker', PIPELINE),
    Executable('marker_projector', _NODES + 'marker_projector', 'MarkerProjector', PIPELINE),
    Executable('choice_arbiter', _NODES + 'choice_arbiter', 'ChoiceArbiter', PIPELINE),
    Executable('choice_menu', _NODES + 'choice_menu', 'ChoiceMenu', MENU),
    Executable('gaze_validation', _NODES + 'gaze_validation', 'GazeValidation'),
    Executable('ssvep_decoder', _NODES + 'ssvep_decoder', 'SsvepDecoder'),
    Executable('ssvep_stimulus_map', _NODES + 'ssvep_stimulus_map', 'SsvepStimulusMap'),
    Executable('ssvep_stimulus', _NODES + 'ssvep_stimulus', 'SsvepStimulus',
               requires=DISPLAY),
    Executable('view_animated_bridge', _NODES + 'view_animated_bridge', 'ViewAnimatedBridge',
               requires='rviz_plugin_view_animated_msgs'),
    Executable('sim_rviz_view', 'eye_bci_ros2.sim.rviz_view', 'SimRvizView', SIM),
    Executable('sim_robot', 'eye_bci_ros2.sim.robot', 'SimRobot', SIM),
    Executable('eye_bci', _NODES + 'eye_bci', group=COMPOSITION),
    Executable('sim_gaze', 'eye_bci_ros2.sim.gaze_outlet', group=SIM),
    Executable('sim_eeg', 'eye_bci_ros2.sim.eeg_outlet', group=SIM),
    Executable('calibrate', 'eye_bci_ros2.tools.calibrate', group=TOOL),
    Executable('find_panel', 'eye_bci_ros2.tools.find_panel', group=TOOL),
    Executable('monitor', 'eye_bci_ros2.tools.monitor', group=TOOL),
    Executable('ssvep_calibrate', 'eye_bci_ros2.tools.ssvep_calibrate', group=TOOL),
    Executable('accuracy_test', 'eye_bci_ros2.experiments.accuracy_test', group=TOOL),
    Executable('demo', 'eye_bci_ros2.experiments.demo', group=TOOL),
)


#: The module every console script enters through: it prepares the process, then imports the
#: executable's module and runs its ``main`` (:mod:`eye_bci_ros2.ros.startup`).
STARTUP_MODULE = 'eye_bci_ros2.ros.startup'


def console_scripts() -> Tuple[str, ...]:
    """Return setuptools' ``console_scripts``: ``'<name> = <startup>:<name>'`` per executable."""
    return tuple(f'{e.name} = {STARTUP_MODULE}:{e.name}' for e in EXECUTABLES)


def parameter_nodes() -> Tuple[Executable, ...]:
    """Return the executables that run a node with declared parameters, in table order."""
    return tuple(e for e in EXECUTABLES if e.node_class)


def _triples(group: str) -> Tuple[Tuple[str, str, str], ...]:
    return tuple((e.name, e.module, e.node_class) for e in EXECUTABLES if e.group == group)


def pipeline() -> Tuple[Tuple[str, str, str], ...]:
    """Return (node name, module, class) of each node ``eye_bci`` composes, in start-up order."""
    return _triples(PIPELINE)


def menu() -> Tuple[str, str, str]:
    """Return (node name, module, class) of the menu ``eye_bci --with-menu`` adds."""
    found, = _triples(MENU)
    return found


def missing(entry: Executable) -> str:
    """Return why ``entry``'s node cannot be created here ('' when it can)."""
    if entry.requires == DISPLAY:
        return '' if os.environ.get('DISPLAY') else 'it opens a window: no X display (DISPLAY)'
    if entry.requires and importlib.util.find_spec(entry.requires) is None:
        return f'{entry.requires} is not installed (built with colcon; README)'
    return ''
