"""
Benchmark: the residual after validation + correction, through the real nodes.

Per seed, on a private ROS domain in one process: a simulated person
(:class:`eye_bci_ros2.sim.gaze_outlet.GazeStreamer`, a real LSL outlet; preset
``original_tobii_4c``: 0.8 deg offset, 0.3 deg jitter, 0.1 deg drift) that
follows ``validation/target`` (:class:`eye_bci_ros2.sim.target_follower.TargetFollower`),
the real ``lsl_gaze_bridge`` reading it, and ``gaze_validation`` (9 targets,
its default 1.5 s each, the person's screen geometry) that validates, fits,
sets the bridge's ``gaze_correction`` and validates again.  Reported: the
accuracy before and the residual accuracy after, degrees, for two people:

* ``offset``: the preset without its drift and with an ideal eye
  (:data:`~eye_bci_ros2.sim.person.IDEAL_EYE`: the 0.8 deg offset and 0.3 deg
  jitter only): what the correction can remove.  Goal: residual <= 0.2 deg.
* ``with_drift``: the preset as it is, a person like recorded people: its
  drift (0.1 deg RMS per axis, a period of 6-13 s) and wander change between
  the two passes and its landings differ from target to target, so no
  one-time correction removes them, nor an offset or affine one the error
  that varies over the screen: the residual is what a person keeps.

Run: ``python -m bench.validation`` (seed 0, both people, about a minute;
``--quick``: the offset person with 5 targets, ~15 s; ``--seeds 0 1 2``).
"""

import argparse
import json
import sys
import time
from typing import Dict, List, Optional, Sequence
import uuid

from domain_coordinator import domain_id
from geometry_msgs.msg import PoseStamped
import rclpy
from rclpy.context import Context
from rclpy.node import Node
from rclpy.parameter import Parameter

from eye_bci_ros2.nodes.gaze_validation import GazeValidation
from eye_bci_ros2.nodes.lsl_gaze_bridge import LslGazeBridge
from eye_bci_ros2.projection.camera_model import look_at_pose
from eye_bci_ros2.ros.conversions import arrays_to_pose
from eye_bci_ros2.ros.runner import make_executor, spin_until
from eye_bci_ros2.ros.startup import quiet_liblsl
from eye_bci_ros2.ros.topics import CAMERA_POSE_TOPIC, LATCHED_QOS
from eye_bci_ros2.sim.gaze_outlet import GazeStreamer
from eye_bci_ros2.sim.person import IDEAL_EYE, PRESETS
from eye_bci_ros2.sim.target_follower import TargetFollower

#: The issue's goal for the 0.8 deg person, degrees.
GOAL_DEG = 0.2
PRESET = 'original_tobii_4c'


def run_once(seed: int, targets: int = 9, drift: bool = True,
             preset: str = PRESET) -> Dict[str, float]:
    """Validate one simulated person through the nodes; return the figures."""
    person = (PRESETS[preset] if drift
              else PRESETS[preset].with_changes(drift_deg=0.0, **IDEAL_EYE))
    screen = person.person.screen
    tag = uuid.uuid4().hex
    streamer = GazeStreamer(params=person, seed=seed, source_id=f'bench-validation-{tag}',
                            name=f'bench_validation_{tag}')
    with domain_id() as domain:
        context = Context()
        rclpy.init(context=context, domain_id=domain)
        executor = make_executor(context=context)
        nodes: List[Node] = []
        try:
            streamer.start()

            def add(node_class, *args, **params):
                node = node_class(*args, context=context, parameter_overrides=[
                    Parameter(k, value=v) for k, v in params.items()])
                nodes.append(node)
                executor.add_node(node)
                return node

            bridge = add(LslGazeBridge, source_id=streamer.info.source_id(),
                         stream_name=streamer.info.name())
            add(TargetFollower, streamer)
            camera = add(Node, 'bench_camera')
            pose = PoseStamped()
            pose.header.frame_id = 'map'
            pose.pose = arrays_to_pose(*look_at_pose((0.0, -4.0, 6.0), (0.0, 0.0, 0.0),
                                                     (0.0, 0.0, 1.0)))
            camera.create_publisher(PoseStamped, CAMERA_POSE_TOPIC, LATCHED_QOS).publish(pose)
            if not spin_until(executor, lambda: bridge.counters['published'] > 50, 15.0):
                raise RuntimeError('no gaze through the bridge')
            started = time.monotonic()
            validation = add(
                GazeValidation, targets=targets, output='', projector_node='',
                screen_width_mm=float(screen.width_mm), screen_height_mm=float(screen.height_mm),
                viewing_distance_mm=float(screen.distance_mm))
            if not spin_until(executor, lambda: validation.exit_status is not None, 120.0):
                raise RuntimeError('the validation did not finish')
            outcome = validation.outcome
            return {'person': 'with_drift' if drift else 'offset', 'seed': seed,
                    'accepted': outcome.accepted,
                    'accuracy_deg': round(outcome.accuracy_deg, 3),
                    'residual_deg': round(outcome.residual_deg, 3),
                    'residual_px': round(outcome.residual_px, 2),
                    'precision_deg': round(outcome.precision_deg, 3),
                    'duration_s': round(time.monotonic() - started, 1)}
        finally:
            streamer.stop()
            executor.shutdown()
            for node in nodes:
                node.destroy_node()
            context.try_shutdown()


def run(quick: bool = False, seeds: Optional[Sequence[int]] = None) -> Dict:
    """Run the seeds for both people (``quick``: the offset person only, 5 targets)."""
    seeds = list(seeds) if seeds is not None else [0]
    targets = 5 if quick else 9
    rows = [run_once(seed, targets, drift) for drift in ((False,) if quick else (False, True))
            for seed in seeds]
    offset = [row for row in rows if row['person'] == 'offset']
    worst = max(row['residual_deg'] for row in offset)
    return {'preset': PRESET, 'targets': targets, 'rows': rows,
            'worst_offset_residual_deg': worst, 'goal_deg': GOAL_DEG,
            'goal_met': all(row['accepted'] for row in offset) and worst <= GOAL_DEG}


def main(argv: Optional[Sequence[str]] = None) -> int:
    """Print the figures (and JSON with --json); status 1 when the goal is missed."""
    quiet_liblsl()     # before the first LSL stream: liblsl quiet, as every executable
    parser = argparse.ArgumentParser(prog='python -m bench.validation',
                                     description=__doc__.strip().split('\n\n')[0])
    parser.add_argument('--quick', action='store_true', help='the offset person only, 5 targets')
    parser.add_argument('--seeds', type=int, nargs='+', help='seeds (default 0)')
    parser.add_argument('--json', action='store_true', help='print the result as JSON')
    args = parser.parse_args(argv)
    result = run(args.quick, args.seeds)
    for row in result['rows']:
        print(f"{row['person']:10s} seed {row['seed']}: accuracy {row['accuracy_deg']:.2f} deg "
              f"-> residual {row['residual_deg']:.2f} deg ({row['residual_px']:.1f} px), "
              f"precision {row['precision_deg']:.2f} deg RMS, "
              f"{'accepted' if row['accepted'] else 'REFUSED'}, {row['duration_s']:.0f} s")
    print(f"{PRESET}, {result['targets']} targets: the offset corrected to at most "
          f"{result['worst_offset_residual_deg']:.2f} deg residual (goal <= {GOAL_DEG} deg: "
          f"{'met' if result['goal_met'] else 'MISSED'})")
    if args.json:
        print(json.dumps(result))
    return 0 if result['goal_met'] else 1


if __name__ == '__main__':
    sys.exit(main())
