"""
One declaration per setting: type, default, range, unit, description, checks.

A settings dataclass (:class:`eye_bci_ros2.decision.rounds.ArbiterSettings`,
:class:`eye_bci_ros2.decision.fusion.FusionSettings`, ...) declares each field with a
:class:`Setting` (``name: float = Setting(...).field()``).  From that one
declaration come:

* the dataclass's checks: :func:`check_settings` in its ``__post_init__``;
* the node parameter: :func:`eye_bci_ros2.ros.parameters.param_specs`
  (ParameterDescriptor with the description and the range, the same check
  when set), and the typed settings object a node keeps
  (:class:`eye_bci_ros2.ros.parameters.SettingsParameters`);
* the generated parameter tables and defaults file
  (``python -m eye_bci_ros2.tools.describe``), which read the declared parameters;
* per-field flags a class needs, as ``field(**flags)`` metadata (the
  arbiter's rule fields, :data:`eye_bci_ros2.decision.rounds.RULE_FIELDS`).

It is what generate_parameter_library does for C++ nodes from a YAML file,
written as Python declarations.  Pure Python.
"""

from dataclasses import dataclass, Field, field, fields, is_dataclass, replace
from typing import Any, Callable, Dict, Optional, Tuple, Type

from eye_bci_ros2.base.validators import in_interval, Interval, is_number, one_of, require

#: Where a field keeps its declaration (``dataclasses.field`` metadata).
_KEY = 'setting'


@dataclass(frozen=True)
class Setting:
    """
    The declaration of one setting.

    :param default: the default; its type is the setting's type (bool, int,
        float, str; a float setting needs a float default).
    :param description: what it means, shown to users (``ros2 param describe``,
        docs/parameters.md); units as they read them.
    :param interval: allowed numbers (None: any); a ROS parameter declares
        its closure and the open ends are checked (:class:`Interval`).
    :param unit: the unit written after the interval in a refusal ('s', 'deg').
    :param why: what the value means, said in a refusal.
    :param choices: allowed texts for a text setting.
    :param check: one more check (returns a reason when the value is wrong).
    :param name: the name, for a declaration used outside a dataclass
        (:meth:`check`); a field's name fills it in (:func:`declarations`).
    """

    default: Any
    description: str
    interval: Optional[Interval] = None
    unit: str = ''
    why: str = ''
    choices: Optional[Tuple[str, ...]] = None
    check_value: Optional[Callable[[Any], Optional[str]]] = None
    name: str = ''

    def __post_init__(self):
        """Refuse a declaration whose default breaks its own rules."""
        reason = self.problem(self.default)
        if reason:
            raise ValueError(f'{self.name or "setting"}: default {reason}')

    def problem(self, value: Any) -> Optional[str]:
        """Return why ``value`` is not acceptable (a phrase after the name), or None."""
        if self.choices is not None:
            reason = one_of(value, self.choices)
            if reason:
                return reason
        if self.interval is not None:
            reason = in_interval(value, self.interval, self.unit, self.why)
            if reason:
                return reason
        elif isinstance(self.default, float) and not is_number(value):
            return f'must be a number, got {value!r}'
        if self.check_value is not None:
            return self.check_value(value)
        return None

    def check(self, value: Any, name: str = '') -> None:
        """Raise ``ValueError`` with the name and the reason when ``value`` is not acceptable."""
        require(name or self.name, self.problem(value))

    def field(self, **flags) -> Any:
        """Return the dataclass field of this setting (``flags`` kept as field metadata)."""
        return field(default=self.default, metadata={_KEY: self, **flags})


def declarations(settings: Any) -> Tuple[Setting, ...]:
    """
    Return the declarations of a settings dataclass (class or instance), named, in order.

    :raises TypeError: a field without a declaration, or one named differently.
    """
    cls = settings if isinstance(settings, type) else type(settings)
    found = _DECLARED.get(cls)
    if found is None:
        found = _DECLARED[cls] = tuple(_declaration(item) for item in fields(cls))
    return found


#: Declarations by class, named (:func:`declarations` reads the fields once per class).
_DECLARED: Dict[type, Tuple[Setting, ...]] = {}


def _declaration(item: Field) -> Setting:
    setting = item.metadata.get(_KEY)
    if setting is None:
        raise TypeError(f'settings field {item.name} has no Setting declaration')
    if setting.name and setting.name != item.name:
        raise TypeError(f'settings field {item.name} is declared as {setting.name}')
    return replace(setting, name=item.name)


def flagged(cls: Type, flag: str) -> Tuple[str, ...]:
    """Return the names of the fields of ``cls`` declared with ``field(flag=True)``."""
    return tuple(item.name for item in fields(cls) if item.metadata.get(flag))


def check_settings(settings: Any) -> None:
    """Raise ``ValueError`` (name and reason) for the first field its declaration refuses."""
    for setting in declarations(settings):
        setting.check(getattr(settings, setting.name))


def values_of(settings: Any) -> Dict[str, Any]:
    """Return ``{name: value}`` of a settings dataclass instance."""
    if not is_dataclass(settings):
        raise TypeError(f'{settings!r} is no settings dataclass')
    return {item.name: getattr(settings, item.name) for item in fields(settings)}
