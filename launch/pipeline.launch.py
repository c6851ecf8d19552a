r"""
The eye_bci_ros2 pipeline: gaze bridge, camera tracker, marker projector, choice arbiter, markers.

    ros2 launch eye_bci_ros2 pipeline.launch.py
    ros2 launch eye_bci_ros2 pipeline.launch.py profile:=tobii_pro \
        params_file:=/path/to/my_params.yaml rviz_config:=/path/to/my.rviz

Each node is its own process and reads ``params_file`` (default: the
installed config/eye_bci.yaml, every default).  ``profile`` (an eye-tracker
profile of lsl_gaze_bridge: tobii_pro, tobii_stream_engine, pupil_capture,
xy_pixels, custom) and ``rviz_config`` (an .rviz file, read by camera_tracker
and marker_projector for the view and the panel size) are applied over the
file when not empty.  The options to choose from are published on
``choices`` by your own node (or ``experiment.launch.py``'s menu).

Nothing starts when ``params_file`` does not exist (one line says so).  Every
node is required: when one ends (a bad parameter at start-up, a crash), the
launch shuts the others down, so no half pipeline keeps running; Ctrl-C, once
or twice, is one quiet stop, status 0 (:mod:`eye_bci_ros2.ros.launch_stop`).
"""

import os

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare

from eye_bci_ros2.ros.launch_stop import one_stop_per_ctrl_c, required

PACKAGE = 'eye_bci_ros2'


def _required(executable):
    """Return the action that ends the launch when ``executable`` ends (its ``on_exit``)."""
    return required(executable, 'a pipeline without it cannot choose')


def _nodes(context):
    """Check the params file, then build the pipeline's nodes with the overrides given."""
    params_file = LaunchConfiguration('params_file').perform(context)
    if not os.path.isfile(params_file):
        raise RuntimeError(f"params_file '{params_file}' does not exist: nothing started")
    profile = LaunchConfiguration('profile').perform(context)
    rviz_config = LaunchConfiguration('rviz_config').perform(context)
    bridge = [{'profile': profile}] if profile else []
    view = [{'rviz_config': rviz_config}] if rviz_config else []
    return [
        Node(package=PACKAGE, executable='lsl_gaze_bridge', name='lsl_gaze_bridge',
             parameters=[params_file] + bridge, output='screen',
             on_exit=_required('lsl_gaze_bridge')),
        Node(package=PACKAGE, executable='camera_tracker', name='camera_tracker',
             parameters=[params_file] + view, output='screen',
             on_exit=_required('camera_tracker')),
        Node(package=PACKAGE, executable='marker_projector', name='marker_projector',
             parameters=[params_file] + view, output='screen',
             on_exit=_required('marker_projector')),
        Node(package=PACKAGE, executable='choice_arbiter', name='choice_arbiter',
             parameters=[params_file], output='screen', on_exit=_required('choice_arbiter')),
        # The session's events on an LSL marker stream for LabRecorder (enabled: false in
        # the params file turns the stream off).
        Node(package=PACKAGE, executable='session_markers', name='session_markers',
             parameters=[params_file], output='screen', on_exit=_required('session_markers')),
    ]


def generate_launch_description():
    """Declare the arguments and the pipeline nodes."""
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
            'rviz_config', default_value='',
            description='.rviz file whose view and panel size camera_tracker and '
                        "marker_projector read; '' = their parameters"),
        OpaqueFunction(function=_nodes),
    ])
