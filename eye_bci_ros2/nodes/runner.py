"""The thin Jazzy ``main`` every executable shares."""

import sys
from typing import Callable, List, Optional

import rclpy
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node


def spin_node(make_node: Callable[[], Node], args: Optional[List[str]] = None) -> None:
    """
    Init rclpy, spin one node until Ctrl-C or shutdown, then clean up.

    A node that refuses to start (a bad parameter override or file) exits with
    status 1 and its reason, not a traceback.

    :param make_node: builds the node (after ``rclpy.init``).
    :param args: command-line arguments (``--ros-args ...``), default sys.argv.
    """
    rclpy.init(args=args)
    node = None
    status = 0
    try:
        node = make_node()
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except (ValueError, InvalidParameterValueException, InvalidParameterTypeException) as error:
        print(f'cannot start: {error}', file=sys.stderr)
        status = 1
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    if status:
        sys.exit(status)
