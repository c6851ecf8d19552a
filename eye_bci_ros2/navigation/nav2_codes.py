"""
nav2's words for how a navigation ended: the one home of its error codes (pure Python).

A ``nav2_msgs/action/NavigateToPose`` result carries ``error_code`` and ``error_msg``. In
Jazzy, bt_navigator reports its own codes (9000s) or passes on the code of the behaviour-tree
node that failed: the planner's (``ComputePathToPose``, 200s) or the controller's
(``FollowPath``, 100s).  sim_robot aborts with the same codes for the same causes, and the
menu says each in words to the person, so a real nav2 and the simulation read alike.
"""

from typing import Dict

# NavigateToPose (bt_navigator).
NONE = 0
UNKNOWN = 9000
FAILED_TO_LOAD_BEHAVIOR_TREE = 9001
TF_ERROR = 9002

# FollowPath (the controller server).
CONTROLLER_UNKNOWN = 100
INVALID_CONTROLLER = 101
CONTROLLER_TF_ERROR = 102
INVALID_PATH = 103
PATIENCE_EXCEEDED = 104
FAILED_TO_MAKE_PROGRESS = 105
NO_VALID_CONTROL = 106

# ComputePathToPose (the planner server).
PLANNER_UNKNOWN = 200
INVALID_PLANNER = 201
PLANNER_TF_ERROR = 202
START_OUTSIDE_MAP = 203
GOAL_OUTSIDE_MAP = 204
START_OCCUPIED = 205
GOAL_OCCUPIED = 206
PLANNER_TIMEOUT = 207
NO_VALID_PATH = 208

#: What each code means, in words a person (or a researcher reading the log) understands.
WORDS: Dict[int, str] = {
    NONE: 'no error',
    UNKNOWN: 'navigation failed for an unknown reason',
    FAILED_TO_LOAD_BEHAVIOR_TREE: 'the navigator could not load its behaviour tree',
    TF_ERROR: "the robot's position is unknown (no transform)",
    CONTROLLER_UNKNOWN: 'the controller failed for an unknown reason',
    INVALID_CONTROLLER: 'no such controller',
    CONTROLLER_TF_ERROR: "the controller does not know the robot's position (no transform)",
    INVALID_PATH: 'the path cannot be followed',
    PATIENCE_EXCEEDED: 'the robot stayed blocked for too long',
    FAILED_TO_MAKE_PROGRESS: 'the robot made no progress',
    NO_VALID_CONTROL: 'the controller found no safe way to move',
    PLANNER_UNKNOWN: 'planning failed for an unknown reason',
    INVALID_PLANNER: 'no such planner',
    PLANNER_TF_ERROR: "the planner does not know the robot's position (no transform)",
    START_OUTSIDE_MAP: 'the robot is outside the map',
    GOAL_OUTSIDE_MAP: 'the goal is outside the map',
    START_OCCUPIED: 'the robot stands on an occupied cell',
    GOAL_OCCUPIED: 'the goal is in a wall or an obstacle',
    PLANNER_TIMEOUT: 'planning took too long',
    NO_VALID_PATH: 'there is no path to the goal',
}


def describe(error_code: int, error_msg: str = '') -> str:
    """Return a result's code in words, with nav2's own message when it has one."""
    words = WORDS.get(int(error_code), f'navigation error {int(error_code)}')
    message = (error_msg or '').strip()
    return f'{words} ({message})' if message and message != words else words
