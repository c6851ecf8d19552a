"""The thin Jazzy ``main`` every executable shares."""

from typing import Callable, List, Optional

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node


def spin_node(make_node: Callable[[], Node], args: Optional[List[str]] = None) -> None:
    """
    Init rclpy, spin one node until Ctrl-C or shutdown, then clean up.

    :param make_node: builds the node (after ``rclpy.init``).
    :param args: command-line arguments (``--ros-args ...``), default sys.argv.
    """
    rclpy.init(args=args)
    node = None
    try:
        node = make_node()
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
