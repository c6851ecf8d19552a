"""
Message types by name: the rclpy class of a type the graph names, and its .msg definition.

``session_record`` subscribes with the type each topic has on the graph, and writes
each type's definition into the bag's schema; ``session_report`` decodes a bag's
messages with the same classes.
"""

import importlib
from typing import Dict


def message_class(type_name: str):
    """
    Import the rclpy class of ``pkg/msg/Type`` (or an action's ``pkg/action/X_FeedbackMessage``).

    :raises ImportError: the package is not installed here.
    """
    package, kind, name = type_name.split('/')
    module = importlib.import_module(f'{package}.{kind}')
    found = getattr(module, name, None)
    if found is None and kind == 'action' and '_' in name:
        action, part = name.split('_', 1)      # NavigateToPose_FeedbackMessage
        owner = getattr(module, action)
        found = getattr(owner, part, None) or getattr(owner.Impl, part, None)
    if found is None:
        raise ImportError(f'{type_name} is not in {package}.{kind}')
    return found


def message_definition_from_class(cls) -> Dict[str, str]:
    """
    Return ``{type: .msg text}`` of an rclpy message class and every type it nests.

    For types the rosbags store lacks (nav2_msgs' action feedback): the fields
    rosidl generated the class from (its ``SLOT_TYPES``), in .msg syntax.
    """
    found: Dict[str, str] = {}
    _collect(cls, found)
    return found


#: rosidl's IDL names of the .msg primitives that differ.
_PRIMITIVES = {'boolean': 'bool', 'octet': 'byte', 'float': 'float32', 'double': 'float64'}


def _type_name(cls) -> str:
    namespaces = cls.__module__.split('.')[:2]
    return '/'.join(namespaces + [cls.__name__])


def _field_type(slot, nested: list) -> str:
    """Return a rosidl type as .msg syntax; nested message types are appended to ``nested``."""
    kind = type(slot).__name__
    if kind in ('UnboundedSequence', 'BoundedSequence', 'Array'):
        inner = _field_type(slot.value_type, nested)
        if kind == 'UnboundedSequence':
            return inner + '[]'
        if kind == 'BoundedSequence':
            return f'{inner}[<={slot.maximum_size}]'
        return f'{inner}[{slot.size}]'
    if kind in ('UnboundedString', 'UnboundedWString'):
        return 'string' if kind == 'UnboundedString' else 'wstring'
    if kind in ('BoundedString', 'BoundedWString'):
        return f"{'string' if kind == 'BoundedString' else 'wstring'}<={slot.maximum_size}"
    if kind == 'NamespacedType':
        name = '/'.join(list(slot.namespaces) + [slot.name])
        nested.append(name)
        return name
    return _PRIMITIVES.get(slot.typename, slot.typename)


def _collect(cls, found: Dict[str, str]) -> None:
    name = _type_name(cls)
    if name in found:
        return
    nested: list = []
    lines = [f'{_field_type(slot, nested)} {field}' for slot, field
             in zip(cls.SLOT_TYPES, cls.get_fields_and_field_types())]
    found[name] = '\n'.join(lines) + '\n'
    for type_name in nested:
        _collect(message_class(type_name), found)
