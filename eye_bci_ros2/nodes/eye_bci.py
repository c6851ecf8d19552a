"""
The whole pipeline in one process: every node on one executor.

Composes lsl_gaze_bridge, camera_tracker, marker_projector, choice_arbiter
and choice_menu (RViz and the eye tracker stay outside).  One executor
(:mod:`eye_bci_ros2.nodes.runner`) runs them all: every callback is short and
non-blocking, so one thread keeps latency low without locks or the GIL
contention of a thread pool.  ``--ros-args`` apply to every node, so name
the node in parameter files (``/marker_projector:``) or use ``/**``.
"""

import importlib
from typing import Any, Dict, List, Optional

from rclpy.context import Context
from rclpy.node import Node
from rclpy.parameter import Parameter

from eye_bci_ros2.nodes.runner import spin_nodes

#: (node name, module, class) of each pipeline node, in start-up order.
PIPELINE = (
    ('lsl_gaze_bridge', 'eye_bci_ros2.nodes.lsl_gaze_bridge', 'LslGazeBridge'),
    ('camera_tracker', 'eye_bci_ros2.nodes.camera_tracker', 'CameraTracker'),
    ('marker_projector', 'eye_bci_ros2.nodes.marker_projector', 'MarkerProjector'),
    ('choice_arbiter', 'eye_bci_ros2.nodes.choice_arbiter', 'ChoiceArbiter'),
    ('choice_menu', 'eye_bci_ros2.nodes.choice_menu', 'ChoiceMenu'),
)

#: Names of the pipeline nodes.
NODE_NAMES = tuple(name for name, _, _ in PIPELINE)


def make_pipeline_nodes(context: Optional[Context] = None,
                        overrides: Optional[Dict[str, Dict[str, Any]]] = None) -> List[Node]:
    """
    Create the pipeline nodes (not yet spinning).

    :param context: rclpy context for all of them (None: the default one).
    :param overrides: ``{node name: {parameter: value}}``; a value may be an
        ``rclpy.parameter.Parameter`` (needed for an empty list, whose type
        cannot be guessed).  They take precedence over ``--ros-args``.
    :returns: the nodes, in :data:`PIPELINE` order.
    :raises ValueError: an unknown node name, or a node that refuses its
        parameters (nodes created so far are destroyed first).
    """
    overrides = dict(overrides or {})
    unknown = sorted(set(overrides) - set(NODE_NAMES))
    if unknown:
        raise ValueError(f'no pipeline node named {", ".join(unknown)} '
                         f'(nodes: {", ".join(NODE_NAMES)})')
    nodes: List[Node] = []
    try:
        for name, module, class_name in PIPELINE:
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
    """Run all pipeline nodes on one executor until Ctrl-C or shutdown."""
    spin_nodes(make_pipeline_nodes, args)


if __name__ == '__main__':
    main()
