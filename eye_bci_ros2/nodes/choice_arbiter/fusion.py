"""
The choice_arbiter's SSVEP input: input-mode parameters, the decoder's topics, the fusion.

:class:`FusionInput` takes the node it serves (as tf2's
``TransformListener(buffer, node)`` does) and owns its part of it: the
input-mode parameters (:class:`eye_bci_ros2.decision.fusion.FusionSettings`), the
subscriptions of the ssvep_decoder's ``ssvep/choice`` (std_msgs/String) and
``ssvep/scores`` (sensor_msgs/JointState, position = posterior), and the
:class:`eye_bci_ros2.decision.fusion.ChoiceFusion` that turns gaze decisions and SSVEP
output into at most one choice per round.  Every input ends in a
:class:`eye_bci_ros2.decision.fusion.FusionOutcome` handed to the node's ``on_outcome``:
the node publishes, the modes are fusion's business.
"""

from typing import Callable, Optional, Sequence

from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import String

from eye_bci_ros2.decision.evidence import Decision
from eye_bci_ros2.decision.fusion import ChoiceFusion, FusionOutcome, FusionSettings, GAZE, SSVEP
from eye_bci_ros2.ros.parameters import param_specs, SettingsParameters
from eye_bci_ros2.ros.topics import EVENT_QOS, SCORES_QOS, SSVEP_CHOICE_TOPIC, SSVEP_SCORES_TOPIC

#: The input-mode parameters (one per FusionSettings field, declared there).
FUSION_PARAMETERS = param_specs(FusionSettings)

#: ``log(level, key, text)``, as :data:`eye_bci_ros2.decision.rounds.LogCallback`.
Log = Callable[[str, str, str], None]


class FusionInput:
    """
    The arbiter's input modes (module doc).

    :param node: the node it declares its parameters and subscriptions on.
    :param on_outcome: called with every outcome that chooses or ends a round.
    :param log: the node's keyed log.
    :param now: the node clock, s.
    """

    def __init__(self, node: Node, on_outcome: Callable[[FusionOutcome], None], log: Log,
                 now: Callable[[], float]):
        """Declare the input-mode parameters and subscribe the SSVEP decoder's output."""
        self._on_outcome = on_outcome
        self._log = log
        self._now = now
        self.parameters = SettingsParameters(node, FusionSettings, self._on_parameters)
        settings = self.parameters.settings
        #: The fusion of gaze and SSVEP (read it; the node feeds it through this object).
        self.fusion = ChoiceFusion(settings)
        self._labels: Optional[tuple] = None
        node.create_subscription(String, SSVEP_CHOICE_TOPIC, self._on_ssvep_choice, EVENT_QOS)
        node.create_subscription(JointState, SSVEP_SCORES_TOPIC, self._on_ssvep_scores,
                                 SCORES_QOS)
        if settings.input_mode != GAZE:
            node.get_logger().info(f'input mode {settings.input_mode}: '
                                   + ('the SSVEP choice chooses' if settings.input_mode ==
                                      SSVEP else 'gaze candidates need SSVEP confirmation'))

    def _on_parameters(self, settings: FusionSettings, changed: dict) -> None:
        self.fusion.configure(settings)

    def offered(self, labels: Sequence[str]) -> None:
        """Start a new fusion round when the set of offered labels changes."""
        labels = tuple(labels)
        if labels != self._labels:
            self._labels = labels
            self.fusion.new_round(labels)

    def new_round(self) -> None:
        """Start a new fusion round on the same options (a choice request)."""
        self.fusion.new_round()

    def gaze(self, decision: Decision) -> None:
        """Take a round's gaze decision."""
        self._emit(self.fusion.gaze_outcome(decision.label, self._now(), decision.margin,
                                            decision.reason))

    def _emit(self, outcome: FusionOutcome) -> None:
        if outcome.choice is not None or outcome.no_choice is not None:
            self._on_outcome(outcome)

    def _on_ssvep_choice(self, msg: String) -> None:
        try:
            self._emit(FusionOutcome(choice=self.fusion.ssvep_choice(msg.data, self._now())))
        except Exception as error:  # noqa: B902 - a node never dies on a message
            self._log('warning', 'ssvep_error', f'SSVEP choice ignored: {error}')

    def _on_ssvep_scores(self, msg: JointState) -> None:
        try:
            if len(msg.name) != len(msg.position):
                self._log('warning', 'ssvep_scores', 'ssvep/scores ignored: name and '
                          'position (posterior) differ in length')
                return
            label = self.fusion.ssvep_scores(list(msg.name), list(msg.position), self._now())
            self._emit(FusionOutcome(choice=label))
        except Exception as error:  # noqa: B902 - a node never dies on a message
            self._log('warning', 'ssvep_error', f'SSVEP scores ignored: {error}')
