"""
The hierarchical room -> table menu of the original experiment.

Offers the rooms of a scene (``scene_file``, see :mod:`eye_bci_ros2.scene`)
as cube markers with the overview camera view; when a room is chosen, moves
the camera to that room's view and offers its tables; when a table is
chosen, reports the outcome ('kitchen/table_2') and starts over at the rooms
(``repeat``) or finishes (offers nothing).

Topics:

* publishes ``choices`` visualization_msgs/MarkerArray (latched): a
  DELETEALL, then one CUBE per option, ``text`` = its label, frame
  ``world_frame``; finishing publishes only the DELETEALL;
* publishes ``camera/goal`` geometry_msgs/PoseStamped (latched): optical
  camera pose (z forward, x right, y down) of the view to show;
* publishes ``choice_menu/result`` std_msgs/String: each outcome;
* publishes ``choice/request`` std_msgs/Empty: asks the choice_arbiter for a
  fresh decision when it would not start one by itself.  The arbiter starts
  a round whenever the set of offered labels changes, which covers every
  normal step (rooms -> tables -> rooms), so the menu requests only when it
  offers the same labels again (a reloaded scene, a new ``world_frame``) and
  after a choice it cannot use (else the arbiter would wait for ever);
* subscribes ``choice`` std_msgs/String: the label chosen; anything that is
  not one of the current options is logged and ignored.

Setting ``scene_file`` (even to its current value) reloads the scene and
starts over at the rooms; a bad file is rejected with the reason and the
current scene kept.
"""

from typing import Any, Dict, Optional, Sequence

from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from std_msgs.msg import Empty, String
from visualization_msgs.msg import Marker, MarkerArray

from eye_bci_ros2.nodes.conversions import arrays_to_pose, cube_marker
from eye_bci_ros2.nodes.parameters import check_frame_id, declare_parameters, ParamSpec
from eye_bci_ros2.nodes.runner import spin_node
from eye_bci_ros2.nodes.topics import EVENT_QOS, LATCHED_QOS
from eye_bci_ros2.scene import CubeMarker, default_scene_path, load_scene, Room, Scene, View
from eye_bci_ros2.view_animation import optical_pose

#: Marker namespaces of the two levels of the menu.
ROOMS_NS = 'rooms'
TABLES_NS = 'tables'


def resolve_scene_path(value: str) -> str:
    """Return the scene file path a ``scene_file`` value names ('' = the default)."""
    return value if value.strip() else default_scene_path()


class ChoiceMenu(Node):
    """Room -> table menu driven by ``choice``; publishes options and camera goals."""

    def __init__(self, **kwargs):
        """Create the node; ``kwargs`` go to :class:`rclpy.node.Node`."""
        super().__init__('choice_menu', **kwargs)
        # A scene_file is loaded once while it is validated and used on apply.
        self._candidate: Optional[tuple] = None
        self._scene: Optional[Scene] = None
        parameters = (
            ParamSpec('scene_file', '',
                      'Scene YAML with rooms, tables and views (empty = the installed '
                      'config/scene.yaml); setting it reloads and starts over',
                      check=self._check_scene_file),
            ParamSpec('repeat', True,
                      'After a table is chosen, start over at the rooms (true) or finish '
                      '(false: offer nothing more)'),
            ParamSpec('world_frame', 'map',
                      "Frame of the markers and camera goals; must match the scene's "
                      'frame_id', check=check_frame_id),
        )
        try:
            values = declare_parameters(self, parameters, self._on_parameters,
                                        check_all=self._check_all)
        except ValueError as error:
            self.get_logger().fatal(f'cannot start: {error}')
            self.destroy_node()
            raise
        self._scene = self._candidate[1]
        self._candidate = None
        self._repeat = values['repeat']
        self._world_frame = values['world_frame']
        self._room: Optional[Room] = None
        self._finished = False
        self._offered: Sequence[str] = ()

        self._choices_pub = self.create_publisher(MarkerArray, 'choices', LATCHED_QOS)
        self._goal_pub = self.create_publisher(PoseStamped, 'camera/goal', LATCHED_QOS)
        self._result_pub = self.create_publisher(String, 'choice_menu/result', EVENT_QOS)
        self._request_pub = self.create_publisher(Empty, 'choice/request', EVENT_QOS)
        self.create_subscription(String, 'choice', self._on_choice, EVENT_QOS)
        self.get_logger().info(
            f'scene {self._scene.source}: rooms {", ".join(self._scene.room_labels)}')
        self._offer_rooms()

    @property
    def scene(self) -> Scene:
        """Return the scene in use."""
        return self._scene

    @property
    def options(self) -> Sequence[str]:
        """Return the labels offered now (empty once finished)."""
        if self._finished:
            return ()
        if self._room is None:
            return self._scene.room_labels
        return tuple(table.marker.text for table in self._room.tables)

    def _on_choice(self, message: String) -> None:
        label = message.data
        try:
            if self._finished:
                self.get_logger().info(f"menu finished: ignoring choice '{label}'")
                return
            if self._room is None:
                room = self._scene.room(label)
                if room is None:
                    self._reject(label)
                    return
                self.get_logger().info(f"room chosen: '{label}'")
                self._offer_tables(room)
                return
            table = self._room.table(label)
            if table is None:
                self._reject(label)
                return
            self._result_pub.publish(String(data=label))
            self.get_logger().info(f"outcome: '{label}'")
            if self._repeat:
                self._offer_rooms()
            else:
                self._finish()
        except Exception as error:  # a message must never kill the node
            self.get_logger().error(f"failed to handle choice '{label}': {error}",
                                    throttle_duration_sec=5.0)

    def _reject(self, label: str) -> None:
        self.get_logger().warning(
            f"ignoring choice '{label}': not one of {', '.join(self.options)}",
            throttle_duration_sec=1.0)
        self._request_pub.publish(Empty())

    def _offer_rooms(self) -> None:
        self._finished = False
        self._room = None
        self._publish_goal(self._scene.overview)
        self._publish_choices([room.marker for room in self._scene.rooms], ROOMS_NS)

    def _offer_tables(self, room: Room) -> None:
        self._room = room
        self._publish_goal(room.view)
        self._publish_choices([table.marker for table in room.tables], TABLES_NS)

    def _finish(self) -> None:
        self._finished = True
        self._room = None
        self._publish_choices([], ROOMS_NS)
        self.get_logger().info('menu finished (repeat is false)')

    def _publish_goal(self, view: View) -> None:
        goal = PoseStamped()
        goal.header.frame_id = self._world_frame
        goal.header.stamp = self.get_clock().now().to_msg()
        goal.pose = arrays_to_pose(*optical_pose(*view.as_tuple()))
        self._goal_pub.publish(goal)

    def _publish_choices(self, markers: Sequence[CubeMarker], ns: str) -> None:
        stamp = self.get_clock().now().to_msg()
        clear = Marker(action=Marker.DELETEALL)
        clear.header.frame_id = self._world_frame
        clear.header.stamp = stamp
        array = MarkerArray(markers=[clear])
        for index, source in enumerate(markers):
            array.markers.append(cube_marker(
                ns, index, source.text, self._world_frame, source.position,
                source.orientation, source.scale, source.color, stamp))
        self._choices_pub.publish(array)
        labels = tuple(marker.text for marker in markers)
        if labels and set(labels) == set(self._offered):
            # Same labels again: the arbiter would not see a change.
            self._request_pub.publish(Empty())
        self._offered = labels

    def _check_scene_file(self, value: str) -> Optional[str]:
        try:
            self._candidate = (value, load_scene(resolve_scene_path(value)))
        except ValueError as error:
            return str(error)
        return None

    def _check_all(self, values: Dict[str, Any]) -> Optional[str]:
        if self._candidate is not None and self._candidate[0] == values['scene_file']:
            scene = self._candidate[1]
        else:
            scene = self._scene
        if scene is not None and scene.frame_id != values['world_frame']:
            return (f"scene {scene.source} is in frame '{scene.frame_id}' but world_frame "
                    f"is '{values['world_frame']}': set frame_id in the scene file to match")
        return None

    def _on_parameters(self, changed: Dict[str, Any]) -> None:
        if 'repeat' in changed:
            self._repeat = changed['repeat']
        if 'world_frame' in changed:
            self._world_frame = changed['world_frame']
        if 'scene_file' in changed and self._candidate is not None:
            self._scene = self._candidate[1]
            self.get_logger().info(
                f'loaded scene {self._scene.source}: rooms {", ".join(self._scene.room_labels)}')
            self._offer_rooms()
        elif 'world_frame' in changed and not self._finished:
            # Re-offer the same options, stamped in the new frame.
            if self._room is None:
                self._offer_rooms()
            else:
                self._offer_tables(self._room)
        self._candidate = None


def main(args=None):
    """Run the choice menu."""
    spin_node(lambda: ChoiceMenu(), args)


if __name__ == '__main__':
    main()
