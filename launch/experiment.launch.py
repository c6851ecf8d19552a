r"""
The original experiment: the pipeline, the room -> table menu, and RViz2.

    ros2 launch eye_bci_ros2 experiment.launch.py
    ros2 launch eye_bci_ros2 experiment.launch.py profile:=pupil_capture \
        params_file:=/path/to/my_params.yaml
    ros2 launch eye_bci_ros2 experiment.launch.py robot:=none   # a real (nav2) robot

Starts ``pipeline.launch.py`` (same ``params_file``, ``profile`` and
``rviz_config``), ``choice_menu`` (which offers the rooms, then the tables,
and moves the camera) and ``rviz2 -d rviz_config`` (default: the installed
config/eye_bci.rviz, whose view and panel size the pipeline reads too, so
what RViz shows and what the projector computes agree).  ``rviz:=false``
starts no RViz2 (one already running with the same file); a value that is
not a boolean (``rviz:=maybe``) is refused with the accepted ones
(:mod:`eye_bci_ros2.ros.launch_arguments`).  ``robot:=sim``
(the default) starts ``sim_robot``, the simulated robot on the scene's map
(``map``, ``plan``, TF; the NavigateToPose action ``navigate_to_pose``);
``robot:=none`` starts no robot: a real one (nav2's bt_navigator) serves
``navigate_to_pose`` to the menu (README, "Robot").  Ctrl-C (launch's
shutdown) cancels the menu's goal: the robot stops when the menu ends.
Another value is refused, naming the accepted ones.

Nothing starts when RViz2 is asked for but not installed, or ``params_file``
does not exist (one line says which).  Every node is required: when one
ends, or RViz2 is closed, the launch shuts the others down.
"""

from ament_index_python.packages import get_package_prefix, PackageNotFoundError
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, IncludeLaunchDescription, OpaqueFunction
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare

from eye_bci_ros2.ros.launch_arguments import boolean_arguments, is_true
from eye_bci_ros2.ros.launch_stop import one_stop_per_ctrl_c, required

PACKAGE = 'eye_bci_ros2'
#: Accepted values of the robot:= argument: the simulated robot, or none (a real one).
ROBOTS = ('sim', 'none')


def _check_rviz(context):
    """Refuse to start anything when RViz2 is asked for but not installed."""
    if not is_true(context, 'rviz'):
        return []
    try:
        get_package_prefix('rviz2')
    except PackageNotFoundError:
        raise RuntimeError('rviz2 is not installed (apt install ros-jazzy-rviz2, then source '
                           '/opt/ros/jazzy/setup.bash), or start without it: rviz:=false; '
                           'nothing started') from None
    return []


def _check_robot(context):
    """Refuse to start anything when robot:= is not one of ROBOTS."""
    robot = LaunchConfiguration('robot').perform(context)
    if robot not in ROBOTS:
        raise RuntimeError(f"robot:='{robot}' is not one of {', '.join(ROBOTS)} (sim: the "
                           'simulated robot; none: a real robot of your own); nothing started')
    return []


def _robot(context):
    """Start the simulated robot when robot:=sim, required like the other nodes."""
    if LaunchConfiguration('robot').perform(context) != 'sim':
        return []
    return [Node(package=PACKAGE, executable='sim_robot', name='sim_robot',
                 parameters=[LaunchConfiguration('params_file').perform(context)],
                 output='screen',
                 on_exit=required('sim_robot', 'the robot is gone'))]


def _menu_and_rviz(context):
    """Add the menu and (with rviz:=true) RViz2, both required."""
    params_file = LaunchConfiguration('params_file').perform(context)
    actions = [Node(package=PACKAGE, executable='choice_menu', name='choice_menu',
                    parameters=[params_file], output='screen',
                    on_exit=required('choice_menu', 'nothing offers the choices'))]
    if is_true(context, 'rviz'):
        actions.append(Node(package='rviz2', executable='rviz2', name='rviz2',
                            arguments=['-d', LaunchConfiguration('rviz_config')],
                            output='screen',
                            on_exit=required('rviz2', 'RViz2 closed')))
    return actions


def generate_launch_description():
    """Declare the arguments, check them, include the pipeline, add robot, menu and RViz2."""
    params_file = LaunchConfiguration('params_file')
    rviz_config = LaunchConfiguration('rviz_config')
    return LaunchDescription([
        one_stop_per_ctrl_c(),
        DeclareLaunchArgument(
            'params_file',
            default_value=PathJoinSubstitution([FindPackageShare(PACKAGE), 'config',
                                                'eye_bci.yaml']),
            description='ROS 2 parameter file for every node (default: all defaults)'),
        DeclareLaunchArgument(
            'profile', default_value='',
            description='eye-tracker profile of lsl_gaze_bridge (tobii_pro, '
                        'tobii_stream_engine, pupil_capture, xy_pixels, custom); '
                        "'' = the params file's"),
        DeclareLaunchArgument(
            'rviz_config',
            default_value=PathJoinSubstitution([FindPackageShare(PACKAGE), 'config',
                                                'eye_bci.rviz']),
            description='.rviz file RViz2 opens and the pipeline reads (view, panel size)'),
        DeclareLaunchArgument(
            'robot', default_value=ROBOTS[0],
            description='the robot: sim (sim_robot, the simulated robot on the scene map) or '
                        'none (a real robot: its nav2 serves the navigate_to_pose action)'),
        # Checked before anything starts (actions run in this order).
        *boolean_arguments(('rviz', True, 'start RViz2')),
        OpaqueFunction(function=_check_robot),
        OpaqueFunction(function=_check_rviz),
        IncludeLaunchDescription(
            PythonLaunchDescriptionSource(PathJoinSubstitution(
                [FindPackageShare(PACKAGE), 'launch', 'pipeline.launch.py'])),
            launch_arguments={'params_file': params_file,
                              'profile': LaunchConfiguration('profile'),
                              'rviz_config': rviz_config}.items()),
        OpaqueFunction(function=_robot),
        OpaqueFunction(function=_menu_and_rviz),
    ])
