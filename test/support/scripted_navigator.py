"""
A scripted stand-in for nav2's bt_navigator: a real NavigateToPose action server on the graph.

A test fixture, not a robot: it moves nothing (sim_robot is the simulated robot).  It
answers as nav2 does, when the test says so: accept or reject a goal, send feedback, end a
goal succeeded or aborted with one of nav2's error codes, take a cancel (and end the goal
CANCELED) or refuse it.  So a node test can meet answers that a real nav2 gives rarely, late
or only on failure, on a real ROS 2 graph with rclpy's own action server.
"""

from typing import List, Optional

from geometry_msgs.msg import PoseStamped
from nav2_msgs.action import NavigateToPose
from rclpy.action import ActionClient, ActionServer, CancelResponse, GoalResponse
from rclpy.node import Node
from rclpy.task import Future

from eye_bci_ros2.ros.topics import NAVIGATE_TO_POSE_ACTION

#: How often a cancelled goal is looked for (and ended CANCELED), s.
CANCEL_POLL_S = 0.02


class ScriptedNavigator(Node):
    """
    A NavigateToPose server whose answers the test chooses (``graph.add(ScriptedNavigator)``).

    :ivar accept: accept goals (False: reject them).
    :ivar accept_cancel: take cancels (False: refuse them).
    :ivar end_cancelled: end a cancelled goal CANCELED at once (False: it stays CANCELING).
    :ivar goals: every goal requested, accepted or not (its PoseStamped).
    :ivar cancels: how many cancel requests came, one per goal they named.
    """

    def __init__(self, accept: bool = True, **kwargs):
        """Serve ``navigate_to_pose``; ``kwargs`` go to :class:`rclpy.node.Node`."""
        super().__init__('scripted_navigator', **kwargs)
        self.accept = accept
        self.accept_cancel = True
        self.end_cancelled = True
        self.goals: List[PoseStamped] = []
        self.cancels = 0
        self.current = None                 # the goal executing now (its ServerGoalHandle)
        self._end: Optional[Future] = None
        self.server = ActionServer(self, NavigateToPose, NAVIGATE_TO_POSE_ACTION,
                                   execute_callback=self._execute,
                                   goal_callback=self._on_goal,
                                   cancel_callback=self._on_cancel)
        self.create_timer(CANCEL_POLL_S, self._end_cancelled)

    def destroy_node(self) -> None:
        """Destroy the action server too (rclpy's destroy_node leaves it, and the node)."""
        self.server.destroy()
        super().destroy_node()

    @property
    def executing(self) -> bool:
        """Tell whether a goal executes now."""
        return self.current is not None

    def _on_goal(self, goal) -> GoalResponse:
        self.goals.append(goal.pose)
        return GoalResponse.ACCEPT if self.accept else GoalResponse.REJECT

    def _on_cancel(self, handle) -> CancelResponse:
        self.cancels += 1
        return CancelResponse.ACCEPT if self.accept_cancel else CancelResponse.REJECT

    async def _execute(self, handle):
        if self.current is not None:         # a new goal preempts the old one, as nav2
            self.finish('abort', 0)
        self.current, self._end = handle, Future()
        return await self._end

    def feedback(self, distance_m: float) -> None:
        """Send feedback on the executing goal: the distance left, m."""
        message = NavigateToPose.Feedback()
        message.distance_remaining = float(distance_m)
        if self.current is not None:
            message.current_pose.header.frame_id = self.current.request.pose.header.frame_id
        self.current.publish_feedback(message)

    def finish(self, how: str, error_code: int = 0, error_msg: str = '') -> None:
        """End the executing goal: ``succeed``, ``abort`` (with nav2's code) or ``canceled``."""
        handle, end = self.current, self._end
        self.current = self._end = None
        getattr(handle, how)()
        end.set_result(NavigateToPose.Result(error_code=error_code, error_msg=error_msg))

    def _end_cancelled(self) -> None:
        if self.end_cancelled and self.current is not None and self.current.is_cancel_requested:
            self.finish('canceled')


class GoalSender(Node):
    """Another client of ``navigate_to_pose`` (a menu that died, RViz's goal tool)."""

    def __init__(self, **kwargs):
        """Make the client; ``kwargs`` go to :class:`rclpy.node.Node`."""
        super().__init__('goal_sender', **kwargs)
        self.client = ActionClient(self, NavigateToPose, NAVIGATE_TO_POSE_ACTION)

    def send(self, frame_id: str = 'map') -> None:
        """Send a goal at the map's origin and forget it."""
        goal = NavigateToPose.Goal()
        goal.pose.header.frame_id = frame_id
        self.client.send_goal_async(goal)

    def destroy_node(self) -> None:
        """Destroy the action client too."""
        self.client.destroy()
        super().destroy_node()
