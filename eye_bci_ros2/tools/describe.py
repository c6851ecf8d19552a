"""
Describe every node's parameters from the nodes themselves.

Creates each node on a private context, reads what it declared (value,
description, range) and prints either the parameter tables of docs/parameters.md
(``--markdown``) or the defaults file ``config/eye_bci.yaml`` (``--yaml``), so
neither can drift from the code.  ``test/system/test_describe.py`` checks both.
The parameters come from their declarations (:mod:`eye_bci_ros2.base.settings`
for the decision's, fusion's and feedback's settings, ParamSpec tables
elsewhere); this tool reads what the nodes made of them.

Usage::

    python -m eye_bci_ros2.tools.describe --yaml > config/eye_bci.yaml
    python -m eye_bci_ros2.tools.describe --markdown
"""

import argparse
import importlib
import os
import sys
from typing import Any, Dict, List, NamedTuple, Optional, Tuple

import rclpy
from rclpy.context import Context
from rclpy.parameter import Parameter

from eye_bci_ros2.ros.registry import Executable, parameter_nodes

#: Every executable that runs a node with parameters, in table order (the registry's).
NODES: Tuple[Executable, ...] = parameter_nodes()

#: Declared by rclpy itself on every node: not ours to document.
_BUILTIN = {'use_sim_time', 'start_type_description_service'}


class ParamInfo(NamedTuple):
    """One declared parameter: name, default (None = empty array), range, description."""

    name: str
    default: Any
    value_range: Optional[str]
    description: str


def describe_nodes(domain: int = 0) -> Dict[str, List[ParamInfo]]:
    """
    Create every node in :data:`NODES` and read its declared parameters.

    :param domain: ROS domain id of the private context (nothing is sent
        that matters, but a free domain keeps it quiet).
    :returns: ``{node name: [ParamInfo, ...]}`` in declaration order.
    """
    context = Context()
    rclpy.init(context=context, domain_id=domain)
    described = {}
    try:
        for entry in NODES:
            module = importlib.import_module(entry.module)
            if entry.requires:
                # Creating it needs a window or a package built apart: describe what its
                # module declares, the same here as on a machine that has them.
                described[entry.name] = [_spec_info(spec) for spec in module.PARAMETERS]
                continue
            node = getattr(module, entry.node_class)(context=context)
            try:
                names = node.list_parameters([], 0).names   # in declaration order
                described[entry.name] = [_info(node, name) for name in names
                                         if name not in _BUILTIN]
            finally:
                node.destroy_node()
    finally:
        context.try_shutdown()
    return described


def _spec_info(spec) -> ParamInfo:
    """Describe a parameter from its ParamSpec (as the node would declare it)."""
    descriptor = spec.descriptor()
    default = list(spec.default) if isinstance(spec.default, (list, tuple)) else spec.default
    return ParamInfo(spec.name, default if default != [] else None,
                     _range_text(descriptor), descriptor.description)


def _info(node, name: str) -> ParamInfo:
    parameter = node.get_parameter_or(name, Parameter(name, Parameter.Type.NOT_SET))
    descriptor = node.describe_parameter(name)
    value = None if parameter.type_ == Parameter.Type.NOT_SET else parameter.value
    if value is not None and not isinstance(value, (str, bool, int, float)):
        value = list(value)
    return ParamInfo(name, value, _range_text(descriptor), descriptor.description)


def _range_text(descriptor) -> Optional[str]:
    """Return a descriptor's range as 'low .. high' (None without one)."""
    for ranges in (descriptor.integer_range, descriptor.floating_point_range):
        if ranges:
            return f'{_format(ranges[0].from_value)} .. {_format(ranges[0].to_value)}'
    return None


def _format(value: Any) -> str:
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, str):
        return f"'{value}'"
    if value is None:
        return '[]'
    if isinstance(value, list):
        return '[' + ', '.join(_format(v) for v in value) + ']'
    return str(value)


def to_yaml(described: Dict[str, List[ParamInfo]]) -> str:
    """Render the defaults as a ROS 2 parameter file."""
    lines = [
        '# Default parameters of every eye_bci_ros2 node, generated from the nodes:',
        '#   python -m eye_bci_ros2.tools.describe --yaml > config/eye_bci.yaml',
        '# Use: ros2 run eye_bci_ros2 <exe> --ros-args --params-file <this file>',
    ]
    for node_name, infos in described.items():
        lines += [f'/{node_name}:', '  ros__parameters:']
        for info in infos:
            if info.default is None:
                # Not set (no default): leave it out of the file.
                lines.append(f'    # {info.name}: []  (empty: {info.description})')
            else:
                lines.append(f'    {info.name}: {_format(info.default)}')
    return '\n'.join(lines) + '\n'


def to_markdown(described: Dict[str, List[ParamInfo]]) -> str:
    """Render one Markdown table of parameters per node."""
    blocks = []
    for node_name, infos in described.items():
        rows = [f'`{node_name}` parameters:', '',
                '| parameter | default | range | meaning |', '|---|---|---|---|']
        for info in infos:
            description = info.description.replace('|', '\\|')
            rows.append(f'| `{info.name}` | `{_format(info.default)}` | '
                        f'{info.value_range or ""} | {description} |')
        blocks.append('\n'.join(rows))
    return '\n\n'.join(blocks) + '\n'


def main(argv: Optional[List[str]] = None) -> int:
    """Print the YAML defaults or the Markdown tables."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0].strip())
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument('--yaml', action='store_true', help='print config/eye_bci.yaml')
    group.add_argument('--markdown', action='store_true', help='print docs/parameters.md tables')
    args = parser.parse_args(argv)
    # The nodes log their start-up; keep stdout for the document.
    os.environ.setdefault('RCUTILS_LOGGING_USE_STDOUT', '0')
    described = describe_nodes(domain=int(os.environ.get('ROS_DOMAIN_ID', '0') or 0))
    sys.stdout.write(to_yaml(described) if args.yaml else to_markdown(described))
    return 0


if __name__ == '__main__':
    sys.exit(main())
