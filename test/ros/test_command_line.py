"""The ROS arguments of a command line, told apart as rcl does, without rcl's warnings."""

from eye_bci_ros2.ros.runner import command_line_problem, non_ros_args


def test_ros_arguments_run_from_each_ros_args_to_a_double_dash_or_the_end():
    assert non_ros_args(['eye_bci', '--ros-args', '-p', 'a:=1', '--', '--with-menu',
                         '--ros-args', '-r', '__ns:=/one']) == ['eye_bci', '--with-menu']
    assert non_ros_args(['monitor', '--once']) == ['monitor', '--once']


def test_a_ros_argument_outside_ros_args_is_named():
    assert command_line_problem(['bridge', '-p', 'profile:=tobii_pro']).startswith(
        "'-p' is a ROS argument and must follow --ros-args")
    assert command_line_problem(['bridge', '--ros-args', '-p', 'profile:=tobii_pro']) is None
