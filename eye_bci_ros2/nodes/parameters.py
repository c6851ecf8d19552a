"""
Declare node parameters from a table: descriptors, validation, live apply.

Every node lists its parameters as :class:`ParamSpec` rows.  rclpy itself
rejects a wrong type or an out-of-range number (from the descriptor); the
``on_set`` callback here rejects the rest (unknown choices, per-value checks,
inconsistent combinations) with a reason, and the ``post_set`` callback hands
accepted values to the node, so ``ros2 param set`` takes effect at once.
"""

from dataclasses import dataclass
import math
from typing import Any, Callable, Dict, Iterable, Optional, Tuple

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rcl_interfaces.msg import ParameterType, SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter

#: A check returns None when the value is fine, else the reason it is not.
Check = Callable[[Any], Optional[str]]

_ARRAY_TYPES = {
    'double_array': ParameterType.PARAMETER_DOUBLE_ARRAY,
    'integer_array': ParameterType.PARAMETER_INTEGER_ARRAY,
    'string_array': ParameterType.PARAMETER_STRING_ARRAY,
}
_EMPTY_ARRAY_TYPES = {
    'double_array': Parameter.Type.DOUBLE_ARRAY,
    'integer_array': Parameter.Type.INTEGER_ARRAY,
    'string_array': Parameter.Type.STRING_ARRAY,
}


@dataclass(frozen=True)
class ParamSpec:
    """
    One parameter of a node.

    :param name: parameter name.
    :param default: default value; for an array that may be empty give an
        empty list and set ``array_type``.
    :param description: shown by ``ros2 param describe``.
    :param value_range: inclusive (low, high) for int or float parameters.
    :param choices: allowed strings for a string parameter.
    :param check: extra per-value check (returns a reason when invalid).
    :param array_type: 'double_array', 'integer_array' or 'string_array'
        for list parameters.
    :param read_only: cannot change after start-up.
    """

    name: str
    default: Any
    description: str
    value_range: Optional[Tuple[float, float]] = None
    choices: Optional[Tuple[str, ...]] = None
    check: Optional[Check] = None
    array_type: Optional[str] = None
    read_only: bool = False

    def descriptor(self) -> ParameterDescriptor:
        """Build the ParameterDescriptor advertised for this parameter."""
        description = self.description
        if self.choices:
            description += f" (one of: {', '.join(self.choices)})"
        descriptor = ParameterDescriptor(description=description, read_only=self.read_only)
        if self.array_type:
            descriptor.type = _ARRAY_TYPES[self.array_type]
        if self.value_range is not None:
            low, high = self.value_range
            if isinstance(self.default, bool) or not isinstance(self.default, (int, float)):
                raise TypeError(f'{self.name}: a range needs a numeric default')
            if isinstance(self.default, int):
                descriptor.integer_range = [IntegerRange(
                    from_value=int(low), to_value=int(high), step=0)]
            else:
                descriptor.floating_point_range = [FloatingPointRange(
                    from_value=float(low), to_value=float(high), step=0.0)]
        return descriptor

    def validate(self, value: Any) -> Optional[str]:
        """Return why ``value`` is not acceptable, or None."""
        if self.choices and value not in self.choices:
            return f"{self.name}: '{value}' is not one of {', '.join(self.choices)}"
        if self.check is not None:
            reason = self.check(value)
            if reason:
                return f'{self.name}: {reason}'
        return None


def declare_parameters(
        node: Node, specs: Iterable[ParamSpec],
        on_change: Callable[[Dict[str, Any]], None],
        check_all: Optional[Callable[[Dict[str, Any]], Optional[str]]] = None,
) -> Dict[str, Any]:
    """
    Declare ``specs`` on ``node`` and keep them validated and applied.

    :param node: the node.
    :param specs: its parameters.
    :param on_change: called after a successful set with ``{name: value}`` of
        what changed (not called for the initial values).
    :param check_all: consistency check over all values after the proposed
        change; returns a reason to reject it.
    :returns: the initial values (overrides applied), ``{name: value}``;
        invalid overrides raise ``ValueError`` at start-up.
    """
    specs = {spec.name: spec for spec in specs}
    for spec in specs.values():
        default = spec.default
        if spec.array_type and not default:
            # An empty list has no type of its own: declare by type (value not set).
            default = _EMPTY_ARRAY_TYPES[spec.array_type]
        node.declare_parameter(spec.name, default, spec.descriptor())
    values = {name: _value_of(node, name, spec) for name, spec in specs.items()}
    for name, spec in specs.items():
        reason = spec.validate(values[name])
        if reason:
            raise ValueError(f'invalid parameter override: {reason}')
    if check_all is not None:
        reason = check_all(dict(values))
        if reason:
            raise ValueError(f'invalid parameter overrides: {reason}')

    def on_set(parameters):
        proposed = {name: _value_of(node, name, specs[name]) for name in specs}
        for parameter in parameters:
            spec = specs.get(parameter.name)
            if spec is None:
                continue
            value = _plain(parameter.value)
            reason = spec.validate(value)
            if reason:
                node.get_logger().warning(f'rejected parameter: {reason}')
                return SetParametersResult(successful=False, reason=reason)
            proposed[parameter.name] = value
        if check_all is not None:
            reason = check_all(proposed)
            if reason:
                node.get_logger().warning(f'rejected parameters: {reason}')
                return SetParametersResult(successful=False, reason=reason)
        return SetParametersResult(successful=True)

    def post_set(parameters):
        changed = {p.name: _plain(p.value) for p in parameters if p.name in specs}
        if changed:
            on_change(changed)

    node.add_on_set_parameters_callback(on_set)
    node.add_post_set_parameters_callback(post_set)
    return values


def check_frame_id(value: Any) -> Optional[str]:
    """Reject an empty frame id or one with a leading slash (tf2 refuses both)."""
    if not str(value).strip():
        return 'must not be empty'
    if str(value).startswith('/'):
        return f"'{value}' must not start with '/'"
    return None


def check_vector3(value: Any) -> Optional[str]:
    """Reject anything but 3 finite numbers (x, y, z)."""
    if value is None or len(value) != 3:
        count = 0 if value is None else len(value)
        return f'needs 3 finite numbers (x, y, z): exactly 3 numbers expected, got {count}'
    if not all(math.isfinite(v) for v in value):
        return 'needs 3 finite numbers (x, y, z): contains NaN or infinite values'
    return None


def _plain(value: Any) -> Any:
    """Arrays come back as array.array or numpy; hand nodes plain lists."""
    if value is not None and not isinstance(value, (str, bytes, bool, int, float)):
        return list(value)
    return value


def _value_of(node: Node, name: str, spec: ParamSpec) -> Any:
    parameter = node.get_parameter_or(name, Parameter(name, Parameter.Type.NOT_SET))
    if parameter.type_ == Parameter.Type.NOT_SET:
        return [] if spec.array_type else None
    return _plain(parameter.value)
