"""
Declare node parameters from a table: descriptors, validation, live apply.

Every node lists its parameters as :class:`ParamSpec` rows.  rclpy itself
rejects a wrong type or an out-of-range number (from the descriptor); the
``on_set`` callback here rejects the rest (unknown choices, per-value checks,
inconsistent combinations) with a reason, and the ``post_set`` callback hands
accepted values to the node, so ``ros2 param set`` takes effect at once.

What a person types is accepted where it means the declared type: the YAML
that ``ros2 param set`` and ``-p name:=value`` parse makes ``1`` an INTEGER,
``[10, -2, 17]`` an INTEGER_ARRAY and ``[]`` an untyped empty list.  So a
double parameter takes an integer, a double array an integer array, any array
an empty list, and a string parameter declared with ``integer_as_text`` (a
channel index, a stream name or id) an integer as its decimal text.  The
conversion (:func:`coerce_parameter`) runs in a ``pre_set`` callback, before
rclpy's type and range checks, so parameters keep their static type (``ros2
param describe`` stays right) and the stored value is the converted one; the
start-up overrides (``--ros-args -p``, ``--params-file``,
``parameter_overrides=``) go through the same conversion before the
parameter is declared.  Anything else of a wrong type is still refused, with
a reason.

``-p "stream_name:=*"`` never reaches a node: rcl's YAML parser reads ``*``
as an alias and fails in ``rclpy.init``.  :func:`quote_param_rules` quotes
such values in the command line first (the executables' ``main`` use it).
"""

import dataclasses
from dataclasses import dataclass
import difflib
import sys
from typing import (Any, Callable, Dict, Generic, Iterable, List, Mapping, Optional, Sequence,
                    Tuple, Type, TypeVar)
import weakref

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rcl_interfaces.msg import ParameterType, SetParametersResult
from rclpy.exceptions import ParameterNotDeclaredException
from rclpy.node import Node
from rclpy.parameter import Parameter

from eye_bci_ros2.base.settings import declarations, Setting
# Re-exported for the nodes' parameter tables: the checks live in eye_bci_ros2.base.validators.
from eye_bci_ros2.base.validators import frame_id as check_frame_id  # noqa: F401
from eye_bci_ros2.base.validators import vector3 as check_vector3  # noqa: F401
from eye_bci_ros2.ros.package_files import package_parameters

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
_ARRAY_PARAMETER_TYPES = (
    Parameter.Type.BOOL_ARRAY, Parameter.Type.BYTE_ARRAY, Parameter.Type.INTEGER_ARRAY,
    Parameter.Type.DOUBLE_ARRAY, Parameter.Type.STRING_ARRAY)
#: What each declared type is called in a reason given to a user.
_TYPE_TEXT = {
    Parameter.Type.BOOL: 'true or false',
    Parameter.Type.INTEGER: 'an integer',
    Parameter.Type.DOUBLE: 'a number',
    Parameter.Type.STRING: 'a text (string)',
    Parameter.Type.BYTE_ARRAY: 'a list of bytes',
    Parameter.Type.BOOL_ARRAY: 'a list of true/false',
    Parameter.Type.INTEGER_ARRAY: 'a list of integers',
    Parameter.Type.DOUBLE_ARRAY: 'a list of numbers',
    Parameter.Type.STRING_ARRAY: 'a list of texts',
}
#: The ParamSpecs of each node whose sets are converted (one pre_set callback per node).
_COERCED: 'weakref.WeakKeyDictionary[Node, Dict[str, ParamSpec]]' = weakref.WeakKeyDictionary()
#: First characters of a YAML value that rcl's parser cannot read unquoted
#: (alias, anchor, tag, block scalar, directive, reserved).
_YAML_INDICATORS = '*&!|>%@`'


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
    :param integer_as_text: a string parameter that also takes an integer,
        as its decimal text (``-p x_channel:=0`` is an INTEGER to ROS).
    """

    name: str
    default: Any
    description: str
    value_range: Optional[Tuple[float, float]] = None
    choices: Optional[Tuple[str, ...]] = None
    check: Optional[Check] = None
    array_type: Optional[str] = None
    read_only: bool = False
    integer_as_text: bool = False

    @property
    def parameter_type(self) -> Parameter.Type:
        """Return the declared type (from ``array_type`` or the default's type)."""
        if self.array_type:
            return _EMPTY_ARRAY_TYPES[self.array_type]
        return Parameter.Type.from_parameter_value(self.default)

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
    _coerce_overrides(node, specs)
    for spec in specs.values():
        default = spec.default
        if spec.array_type and not default:
            # An empty list has no type of its own (rclpy would guess a byte array):
            # declare by type, then give it an empty list of that type.  A parameter left
            # "not set" makes every GetParameters request that names it return no values at
            # all: `ros2 param dump` would print an empty node.
            default = _EMPTY_ARRAY_TYPES[spec.array_type]
            node.declare_parameter(spec.name, default, spec.descriptor())
            unset = Parameter(spec.name, Parameter.Type.NOT_SET)
            if node.get_parameter_or(spec.name, unset).type_ == Parameter.Type.NOT_SET:
                if spec.read_only:
                    raise TypeError(f'{spec.name}: a read-only array needs a non-empty default')
                node.set_parameters([Parameter(spec.name, default, [])])
            continue
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

    _coerce_on_set(node, specs)
    node.add_on_set_parameters_callback(on_set)
    node.add_post_set_parameters_callback(post_set)
    return values


def param_spec(setting: Setting) -> ParamSpec:
    """
    Return the parameter row of a declared setting (:mod:`eye_bci_ros2.base.settings`).

    Name, default, description and choices as declared; the range is the
    closure of the declared interval (rclpy checks it); the declaration's own
    check refuses the rest (an open end, a wrong choice) with its reason.
    """
    interval = setting.interval
    return ParamSpec(setting.name, setting.default, setting.description,
                     value_range=interval.closure if interval is not None else None,
                     choices=setting.choices, check=setting.problem)


def param_specs(settings: Any) -> Tuple[ParamSpec, ...]:
    """Return the parameter rows of a settings dataclass (or of declarations), in order."""
    if isinstance(settings, type):
        settings = declarations(settings)
    return tuple(param_spec(setting) for setting in settings)


S = TypeVar('S')


class SettingsParameters(Generic[S]):
    """
    A settings dataclass kept as a node's parameters: declared, checked, live, typed.

    Declares one parameter per field (:func:`param_specs`); a set that makes
    no valid settings object (a field, or the whole: the dataclass's
    ``__post_init__``) is refused with its reason; an accepted one replaces
    :attr:`settings` and calls ``on_change``.

    :param node: the node.
    :param settings_class: the settings dataclass (every field declared).
    :param on_change: called with (new settings, ``{name: value}`` changed)
        after a successful set; not for the initial values.
    :raises ValueError: start-up overrides that make no valid settings.
    """

    def __init__(self, node: Node, settings_class: Type[S],
                 on_change: Optional[Callable[[S, Dict[str, Any]], None]] = None):
        """Declare the parameters and build the settings from their start-up values."""
        self._class = settings_class
        self._on_change = on_change
        #: The parameter rows (for help texts and tools).
        self.specs = param_specs(settings_class)
        values = declare_parameters(node, self.specs, self._changed, self._problem)
        #: The settings in force; read them, replace them only through the parameters.
        self.settings: S = settings_class(**values)

    def _problem(self, values: Dict[str, Any]) -> Optional[str]:
        try:
            self._class(**values)
        except ValueError as error:
            return str(error)
        return None

    def _changed(self, changed: Dict[str, Any]) -> None:
        self.settings = dataclasses.replace(self.settings, **changed)
        if self._on_change is not None:
            self._on_change(self.settings, changed)


def _coerce_on_set(node: Node, specs: Dict[str, ParamSpec]) -> None:
    """
    Convert every set of ``specs`` on ``node`` before rclpy checks its type.

    One ``pre_set`` callback per node, whatever the number of tables declared
    on it: rclpy concatenates the lists that pre_set callbacks return, so a
    second callback would set every parameter twice.
    """
    table = _COERCED.get(node)
    if table is None:
        table = _COERCED[node] = {}

        def pre_set(parameters):
            for parameter in parameters:
                if not node.has_parameter(parameter.name) and not getattr(
                        node, '_allow_undeclared_parameters', False):
                    # rclpy would refuse it ("not declared"); refuse it saying which name
                    # was meant, in the log and in the answer to ros2 param set.
                    text = unknown_name_text(parameter.name, node.list_parameters([], 0).names)
                    node.get_logger().warning(text)
                    raise UndeclaredParameter(text)
            return [coerce_parameter(table[p.name], p) if p.name in table else p
                    for p in parameters]

        node.add_pre_set_parameters_callback(pre_set)
    table.update(specs)


def coerce_parameter(spec: ParamSpec, parameter: Parameter) -> Parameter:
    """
    Convert what a person typed to the declared type, where it means that type.

    An integer for a double, an integer array for a double array, an empty
    list of any type for an array, an integer for a string parameter with
    ``integer_as_text``.  Anything else is returned unchanged, for rclpy to
    refuse (wrong type) or accept (right type).

    :param spec: the parameter's row.
    :param parameter: the value as it arrived (service call or override).
    :returns: a parameter of the declared type, or ``parameter`` itself.
    """
    declared, given = spec.parameter_type, parameter.type_
    if given == declared:
        return parameter
    value = parameter.value
    if declared == Parameter.Type.DOUBLE and given == Parameter.Type.INTEGER:
        return Parameter(parameter.name, declared, float(value))
    if declared == Parameter.Type.DOUBLE_ARRAY and given == Parameter.Type.INTEGER_ARRAY:
        return Parameter(parameter.name, declared, [float(v) for v in value])
    if declared in _ARRAY_PARAMETER_TYPES and given in _ARRAY_PARAMETER_TYPES \
            and len(value) == 0:
        return Parameter(parameter.name, declared, [])
    if declared == Parameter.Type.STRING and given == Parameter.Type.INTEGER \
            and spec.integer_as_text:
        return Parameter(parameter.name, declared, str(value))
    return parameter


def type_problem(spec: ParamSpec, parameter: Parameter) -> Optional[str]:
    """Return why ``parameter`` cannot be ``spec``'s type even after conversion, or None."""
    declared, given = spec.parameter_type, coerce_parameter(spec, parameter).type_
    if given in (declared, Parameter.Type.NOT_SET):
        return None
    accepted = _TYPE_TEXT[declared]
    if spec.integer_as_text:
        accepted += ' or an integer'
    return (f'{spec.name}: expected {accepted}, got {_TYPE_TEXT.get(given, given.name)} '
            f'{parameter.value!r}')


def _coerce_overrides(node: Node, specs: Dict[str, ParamSpec]) -> None:
    """
    Convert the node's start-up overrides of ``specs`` in place, or refuse them.

    rclpy takes overrides from its ``_parameter_overrides`` dict (filled from
    the command line, parameter files and ``parameter_overrides=``) when a
    parameter is declared, and runs no ``pre_set`` callback then; converting
    the entries first gives start-up the same rules as ``ros2 param set``.

    :raises ValueError: an override of a type that does not convert, with a reason.
    """
    overrides = start_up_overrides(node)
    for name, spec in specs.items():
        if name in overrides:
            reason = type_problem(spec, overrides[name])
            if reason:
                raise ValueError(f'invalid parameter override: {reason}')
            overrides[name] = coerce_parameter(spec, overrides[name])


def start_up_overrides(node: Node) -> Dict[str, Parameter]:
    """
    Return the node's start-up overrides, ``{name: Parameter}`` (the dict itself).

    rclpy (7.1, Jazzy) keeps them only in the private ``Node._parameter_overrides``
    (filled from ``--ros-args -p``, ``--params-file`` and ``parameter_overrides=``)
    and has no public way to read one before its parameter is declared, nor an
    override of a name never declared: this is the one place that reads it.
    An rclpy without it gives an empty dict (no conversion, no typo warnings).
    """
    overrides = getattr(node, '_parameter_overrides', None)
    return overrides if isinstance(overrides, dict) else {}


#: Parameters that rclpy and ROS tools may give any node; never a user's typo.
_ROS_PARAMETERS = ('use_sim_time', 'start_type_description_service')
#: Prefix of the QoS override parameters (``qos_overrides./topic...``).
_QOS_PREFIX = 'qos_overrides.'


def unknown_name_text(name: str, known: Iterable[str],
                      elsewhere: Optional[Mapping[str, Sequence[str]]] = None) -> str:
    """
    Say that ``name`` is no parameter here, with the name probably meant and whose it is.

    :param name: the name given (``-p``, a params file, ``ros2 param set``).
    :param known: the parameter names that exist here.
    :param elsewhere: every node's parameter names, ``{node: names}`` (default: the
        package's, :func:`~eye_bci_ros2.ros.package_files.package_parameters`): a name
        (or the close one) that only another node has is said to be that node's.
    :returns: one line, e.g. ``unknown parameter 'image_widht' ignored: did you
        mean 'image_width'?``, or ``unknown parameter 'screen_ofset_x' ignored: did
        you mean 'screen_offset_x'? That is a parameter of marker_projector, not of
        this node``.
    """
    known = list(known)
    owners: Dict[str, List[str]] = {}
    for node, names in (package_parameters() if elsewhere is None else elsewhere).items():
        for other in names:
            if other not in known:
                owners.setdefault(other, []).append(node)
    close = difflib.get_close_matches(name, known + list(owners), n=1, cutoff=0.6)
    if name in owners:
        hint = f'it is a parameter of {" and ".join(owners[name])}, not of this node'
    elif not close:
        hint = 'ros2 param list shows the names'
    elif close[0] in owners:
        hint = (f"did you mean '{close[0]}'? That is a parameter of "
                f'{" and ".join(owners[close[0]])}, not of this node')
    else:
        hint = f"did you mean '{close[0]}'?"
    return f"unknown parameter '{name}' ignored: {hint}"


class UndeclaredParameter(ParameterNotDeclaredException):
    """
    rclpy's refusal of an undeclared parameter, saying which name was meant.

    rclpy answers ``ros2 param set`` of an undeclared name with the text of the
    ``ParameterNotDeclaredException`` it catches (its set-parameters service puts
    ``str(error)`` into the result's ``reason``), which by itself says only
    ``Invalid access to undeclared parameter(s): ...``.  Raised by the node's
    pre-set callback with :func:`unknown_name_text`, the command line's answer
    carries the hint.
    """

    def __init__(self, text: str):
        """Hold ``text`` as the whole message."""
        Exception.__init__(self, text)


def unknown_overrides(nodes: Iterable[Node]) -> Dict[str, str]:
    """
    Find start-up overrides (``-p``, ``--params-file``) that no node declared.

    rclpy keeps an override of an undeclared name silently, so a typo such as
    ``-p screen_ofset_x:=64`` would leave the node on its default.  Nodes that
    share a process (``eye_bci``) share the command line: a name counts as
    known when any of them declares it.

    :param nodes: the nodes of one process, after their ``__init__``.
    :returns: ``{unknown name: one line for the user}``.
    """
    nodes = list(nodes)
    declared = set()
    for node in nodes:
        declared.update(node.list_parameters([], 0).names)
    unknown: Dict[str, str] = {}
    for node in nodes:
        for name in start_up_overrides(node):
            if name in declared or name in _ROS_PARAMETERS or name.startswith(_QOS_PREFIX):
                continue
            unknown.setdefault(name, unknown_name_text(name, declared))
    return unknown


def warn_unknown_overrides(nodes: Iterable[Node]) -> List[str]:
    """Log :func:`unknown_overrides` once each, on the first node's logger; return the lines."""
    nodes = list(nodes)
    lines = list(unknown_overrides(nodes).values())
    for line in lines:
        nodes[0].get_logger().warning(line)
    return lines


def quote_param_rules(args: Optional[List[str]] = None) -> List[str]:
    """
    Quote ``-p name:=value`` values that rcl's YAML parser cannot read bare.

    ``-p stream_name:=*`` (any stream) makes ``rclpy.init`` fail ("Couldn't
    parse parameter override rule"): ``*`` starts a YAML alias.  A value that
    starts with a YAML indicator (``* & ! | > % @ ```) is wrapped in single
    quotes, so it arrives as the text typed.  Only rules inside ``--ros-args``
    are touched.

    :param args: the command line, as ``rclpy.init(args=...)`` takes it;
        None = ``sys.argv``.
    :returns: a copy with those values quoted.
    """
    if args is None:
        args = sys.argv
    quoted, in_ros_args, expect_rule = [], False, False
    for arg in args:
        if expect_rule:
            arg = _quote_rule(arg)
            expect_rule = False
        elif arg == '--ros-args':
            in_ros_args = True
        elif arg == '--':
            in_ros_args = False
        elif in_ros_args and arg in ('-p', '--param'):
            expect_rule = True
        quoted.append(arg)
    return quoted


def _quote_rule(rule: str) -> str:
    name, separator, value = rule.partition(':=')
    if not separator or not value or value[0] not in _YAML_INDICATORS:
        return rule
    return name + separator + "'" + value.replace("'", "''") + "'"


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
