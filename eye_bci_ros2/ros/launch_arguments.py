"""
Boolean launch arguments, checked: ``rviz:=maybe`` is refused, not read as false.

``launch`` takes any text for an argument, and a launch file that compares
it with ``'true'`` reads a typo as false without a word.  The launch files
of ``launch/`` declare each boolean argument with :func:`boolean_arguments`,
which adds one check, run before anything starts, that refuses a value
outside :data:`TRUE_VALUES` / :data:`FALSE_VALUES` with a one-line reason
naming the accepted values (``ros2 launch`` prints it and exits 1), and read
it with :func:`is_true`.  The accepted values are those of launch's own
conditions (``IfCondition``), in any case.

``launch`` is imported where actions are built: it is not on PyPI, and the
rule (:func:`parse_boolean`) is tested without it.
"""

from typing import List, Tuple

#: What launch's conditions read as true and as false (compared in lower case).
TRUE_VALUES = ('true', '1')
FALSE_VALUES = ('false', '0')


def parse_boolean(name: str, value: str) -> bool:
    """
    Read a boolean launch argument's text.

    :raises ValueError: the text is none of the accepted values (the reason names them).
    """
    text = value.strip().lower()
    if text in TRUE_VALUES:
        return True
    if text in FALSE_VALUES:
        return False
    accepted = ', '.join(TRUE_VALUES + FALSE_VALUES)
    raise ValueError(f"{name}:='{value}' is not a boolean (accepted: {accepted}; any case): "
                     'nothing started')


def is_true(context, name: str) -> bool:
    """Read the boolean argument ``name`` in a launch context (checked before: valid)."""
    return parse_boolean(name, context.launch_configurations[name])


def boolean_arguments(*arguments: Tuple[str, bool, str]) -> List:
    """
    Declare boolean launch arguments and the check that refuses anything else.

    :param arguments: ``(name, default, description)`` each.
    :returns: the ``DeclareLaunchArgument`` actions, then the check (an
        ``OpaqueFunction``): put them before any action that starts something.
    """
    from launch.actions import DeclareLaunchArgument, OpaqueFunction

    def check(context):
        for name, _, _ in arguments:
            try:
                parse_boolean(name, context.launch_configurations[name])
            except ValueError as error:
                raise RuntimeError(str(error)) from None
        return []

    declarations = [
        DeclareLaunchArgument(name, default_value=str(default).lower(),
                              description=f'{description} (true or false)')
        for name, default, description in arguments]
    return declarations + [OpaqueFunction(function=check)]
