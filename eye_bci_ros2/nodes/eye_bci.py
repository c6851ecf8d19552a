"""
The whole pipeline in one process: every node on one executor.

Composes the pipeline nodes, lsl_gaze_bridge, camera_tracker,
marker_projector, choice_arbiter and session_markers (the session's events on
an LSL marker stream, for LabRecorder); RViz, the eye tracker and the task that
publishes ``choices`` stay outside.  The original experiment's menu is
started explicitly: ``ros2 run eye_bci_ros2 choice_menu``, or
``eye_bci --with-menu`` to compose it too.  One executor
(:mod:`eye_bci_ros2.ros.runner`) runs them all: every callback is short and
non-blocking, so one thread keeps latency low without locks or the GIL
contention of a thread pool.  ``--ros-args`` apply to every node, so name
the node in parameter files (``/marker_projector:``) or use ``/**``.
"""

import importlib
import sys
from typing import Any, Dict, List, Optional

from rclpy.context import Context
from rclpy.node import Node
from rclpy.parameter import Parameter

from eye_bci_ros2.ros import registry
from eye_bci_ros2.ros.runner import non_ros_args, spin_nodes

#: (node name, module, class) of each pipeline node, in start-up order (from the registry).
PIPELINE = registry.pipeline()
#: The original experiment's menu, composed only when asked for.
MENU = registry.menu()
#: The command-line option that composes :data:`MENU` too.
WITH_MENU = '--with-menu'


#: Names of the pipeline nodes.
NODE_NAMES = tuple(name for name, _, _ in PIPELINE)


def make_pipeline_nodes(context: Optional[Context] = None,
                        overrides: Optional[Dict[str, Dict[str, Any]]] = None,
                        with_menu: bool = False) -> List[Node]:
    """
    Create the pipeline nodes (not yet spinning).

    :param context: rclpy context for all of them (None: the default one).
    :param overrides: ``{node name: {parameter: value}}``; a value may be an
        ``rclpy.parameter.Parameter`` (needed for an empty list, whose type
        cannot be guessed).  They take precedence over ``--ros-args``.
    :param with_menu: add the original experiment's menu (:data:`MENU`) last.
    :returns: the nodes, in :data:`PIPELINE` order (then the menu).
    :raises ValueError: an unknown node name, or a node that refuses its
        parameters (nodes created so far are destroyed first).
    """
    overrides = dict(overrides or {})
    composed = PIPELINE + ((MENU,) if with_menu else ())
    names = [name for name, _, _ in composed]
    unknown = sorted(set(overrides) - set(names))
    if unknown:
        raise ValueError(f'no pipeline node named {", ".join(unknown)} '
                         f'(nodes: {", ".join(names)})')
    nodes: List[Node] = []
    try:
        for name, module, class_name in composed:
            # Imported here: each node pulls in its own dependencies (pylsl, ...).
            node_class = getattr(importlib.import_module(module), class_name)
            kwargs: Dict[str, Any] = {}
            if context is not None:
                kwargs['context'] = context
            values = overrides.get(name, {})
            if values:
                kwargs['parameter_overrides'] = [
                    value if isinstance(value, Parameter) else Parameter(key, value=value)
                    for key, value in values.items()]
            nodes.append(node_class(**kwargs))
    except BaseException:
        for node in nodes:
            node.destroy_node()
        raise
    return nodes


def main(args=None):
    """Run the pipeline nodes (and the menu with --with-menu) until Ctrl-C or shutdown."""
    argv = list(sys.argv if args is None else args)
    with_menu = WITH_MENU in non_ros_args(argv)[1:]
    spin_nodes(lambda: make_pipeline_nodes(with_menu=with_menu), argv,
               help_modules=[__name__] + [module for _, module, _ in PIPELINE + (MENU,)],
               usage=f'ros2 run eye_bci_ros2 eye_bci [{WITH_MENU}]',
               options=[(WITH_MENU, 'compose choice_menu too (the original experiment)')])


if __name__ == '__main__':
    main()
