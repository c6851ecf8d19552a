r"""
The original experiment: the pipeline, the room -> table menu, and RViz2.

    ros2 launch eye_bci_ros2 experiment.launch.py
    ros2 launch eye_bci_ros2 experiment.launch.py profile:=pupil_capture \
        params_file:=/path/to/my_params.yaml

Starts ``pipeline.launch.py`` (same ``params_file``, ``profile`` and
``rviz_config``), ``choice_menu`` (which offers the rooms, then the tables,
and moves the camera) and ``rviz2 -d rviz_config`` (default: the installed
config/eye_bci.rviz, whose view and panel size the pipeline reads too, so
what RViz shows and what the projector computes agree).  ``rviz:=false``
starts no RViz2 (one already running with the same file).
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, IncludeLaunchDescription
from launch.conditions import IfCondition
from launch.launch_description_sources import PythonLaunchDescriptionSource
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import Node
from launch_ros.substitutions import FindPackageShare

PACKAGE = 'eye_bci_ros2'


def generate_launch_description():
    """Declare the arguments, include the pipeline, add the menu and RViz2."""
    params_file = LaunchConfiguration('params_file')
    rviz_config = LaunchConfiguration('rviz_config')
    return LaunchDescription([
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
            'rviz', default_value='true', description='start RViz2 (true/false)'),
        IncludeLaunchDescription(
            PythonLaunchDescriptionSource(PathJoinSubstitution(
                [FindPackageShare(PACKAGE), 'launch', 'pipeline.launch.py'])),
            launch_arguments={'params_file': params_file,
                              'profile': LaunchConfiguration('profile'),
                              'rviz_config': rviz_config}.items()),
        Node(package=PACKAGE, executable='choice_menu', name='choice_menu',
             parameters=[params_file], output='screen'),
        Node(package='rviz2', executable='rviz2', name='rviz2',
             arguments=['-d', rviz_config], condition=IfCondition(LaunchConfiguration('rviz')),
             output='screen'),
    ])
