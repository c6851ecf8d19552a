"""session_record: a real process records the session's topics into a bag rosbags reads back."""

import os
from pathlib import Path
import shutil
import subprocess

from geometry_msgs.msg import PoseStamped
from mcap.reader import make_reader
import numpy as np
from package_commands import running
import pytest
from rclpy.node import Node
from ros_harness import gaze_messages, ros_graph
from rosbags.highlevel import AnyReader
from rosbags.interfaces import QosDurability
from rosbags.typesys import get_typestore, Stores
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import String
import yaml

from eye_bci_ros2.recordings.bag_writer import RESERVE_NAME
from eye_bci_ros2.ros.topics import (CAMERA_POSE_TOPIC, CHOICE_TOPIC, EVENT_QOS, GAZE_QOS,
                                     GAZE_SAMPLES_TOPIC, LATCHED_QOS)

MODULE = 'tools.session_record'


def read_bag(path: Path):
    """Return {topic: [(log time ns, message)]} and the connections, read with rosbags."""
    found = {}
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        for connection, stamp, data in reader.messages():
            found.setdefault(connection.topic, []).append(
                (stamp, reader.deserialize(data, connection.msgtype)))
        connections = {c.topic: c for c in reader.connections}
    return found, connections


def wait_recording(graph, process, topics, timeout=30.0):
    """Spin until the recorder subscribed to every topic (its subscriptions on the graph)."""
    helper = graph.node('probe')

    def subscribed():
        return all(helper.get_subscriptions_info_by_topic('/' + t) for t in topics)
    assert graph.spin_until(subscribed, timeout), process.output()


def test_ctrl_c_closes_a_bag_that_rosbags_reads_with_types_counts_and_latched_qos(tmp_path):
    bag = tmp_path / 'session'
    with ros_graph() as graph:
        node = graph.node('session_publisher')
        pose = node.create_publisher(PoseStamped, CAMERA_POSE_TOPIC, LATCHED_QOS)
        gaze = node.create_publisher(PointCloud2, GAZE_SAMPLES_TOPIC, GAZE_QOS)
        choice = node.create_publisher(String, CHOICE_TOPIC, EVENT_QOS)
        latched = PoseStamped()
        latched.header.frame_id = 'map'
        latched.pose.position.x = 1.5
        pose.publish(latched)          # before the recorder exists: latched, must arrive
        with running(MODULE, '-o', str(bag), log=tmp_path / 'record.log',
                     domain=graph.domain) as process:
            assert process.wait_for('recording into')
            wait_recording(graph, process, [CAMERA_POSE_TOPIC, GAZE_SAMPLES_TOPIC,
                                            CHOICE_TOPIC])
            stamps = 100.0 + np.arange(240) / 1200.0
            points = np.column_stack([np.linspace(0, 1919, 240), np.full(240, 540.0)])
            messages = gaze_messages(points, stamps)
            for message in messages:
                gaze.publish(message)
            choice.publish(String(data='kitchen'))
            graph.spin_for(1.0)
            process.interrupt()
            assert process.finish() == 0, process.output()
    assert 'closed: ' in process.output() and 'Traceback' not in process.output()
    found, connections = read_bag(bag)
    assert len(found['/gaze/samples']) == len(messages)
    assert [m.data for _, m in found['/choice']] == ['kitchen']
    (_, recorded_pose), = found['/camera/pose']
    assert recorded_pose.pose.position.x == 1.5
    assert connections['/gaze/samples'].msgtype == 'sensor_msgs/msg/PointCloud2'
    assert connections['/camera/pose'].msgtype == 'geometry_msgs/msg/PoseStamped'
    # The latched topic is stored with its publisher's offered transient local QoS.
    qos = connections['/camera/pose'].ext.offered_qos_profiles
    assert qos and qos[0].durability == QosDurability.TRANSIENT_LOCAL
    assert connections['/choice'].ext.offered_qos_profiles[0].durability == \
        QosDurability.VOLATILE
    # rosbag2's metadata.yaml as Jazzy writes it: version 9, mcap, hashes, QoS lists.
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert meta['version'] == 9 and meta['storage_identifier'] == 'mcap'
    topics = {t['topic_metadata']['name']: t for t in meta['topics_with_message_count']}
    assert topics['/gaze/samples']['message_count'] == len(messages)
    assert topics['/camera/pose']['topic_metadata']['type_description_hash'].startswith(
        'RIHS01_')
    assert topics['/camera/pose']['topic_metadata']['offered_qos_profiles'][0][
        'durability'] == 'transient_local'
    assert not (bag / RESERVE_NAME).exists()
    # The MCAP file as the format's own reader sees it (CRCs checked): the ros2 profile,
    # CDR messages, ros2msg schemas, each channel with its QoS and the type's RIHS01 hash
    # (the publisher's, as rosbag2 on Jazzy stores it).
    typestore = get_typestore(Stores.ROS2_JAZZY)
    (mcap_file,) = bag.glob('*.mcap')
    with open(mcap_file, 'rb') as stream:
        reader = make_reader(stream, validate_crcs=True)
        assert reader.get_header().profile == 'ros2'
        summary = reader.get_summary()
        channels = {c.topic: c for c in summary.channels.values()}
        for topic, channel in channels.items():
            schema = summary.schemas[channel.schema_id]
            assert channel.message_encoding == 'cdr' and schema.encoding == 'ros2msg'
            assert set(channel.metadata) == {'offered_qos_profiles', 'topic_type_hash'}
            assert channel.metadata['topic_type_hash'] == typestore.hash_rihs01(schema.name)
            assert topics[topic]['topic_metadata']['type_description_hash'] == \
                channel.metadata['topic_type_hash']
        assert 'durability: transient_local' in \
            channels['/camera/pose'].metadata['offered_qos_profiles']
        assert summary.statistics.message_count == sum(1 for _ in reader.iter_messages()) \
            == meta['message_count']


def test_an_unwritable_path_is_one_line_and_status_1(tmp_path):
    blocker = tmp_path / 'a_file'
    blocker.write_text('in the way')
    with ros_graph() as graph:
        with running(MODULE, '-o', str(blocker / 'bag'), log=tmp_path / 'record.log',
                     domain=graph.domain) as process:
            status = process.finish()
    lines = process.output().strip().splitlines()
    assert status == 1
    path = blocker / 'bag'
    assert lines == [f'session_record: cannot record into {path}: Not a directory']


def test_an_existing_bag_is_never_overwritten(tmp_path):
    (tmp_path / 'bag').mkdir()
    with ros_graph() as graph:
        with running(MODULE, '-o', str(tmp_path / 'bag'), log=tmp_path / 'record.log',
                     domain=graph.domain) as process:
            status = process.finish()
    assert status == 1
    assert 'exists already' in process.output() and 'Traceback' not in process.output()


@pytest.fixture
def small_disk(tmp_path):
    """Mount a real 3 MiB file system (tmpfs): the disk fills mid-run as a real one does."""
    mount = tmp_path / 'small_disk'
    mount.mkdir()
    if shutil.which('mount') is None or os.geteuid() != 0:
        pytest.skip('mounting a small tmpfs needs root and mount(8)')
    done = subprocess.run(['mount', '-t', 'tmpfs', '-o', 'size=3m', 'tmpfs', str(mount)],
                          capture_output=True, text=True)
    if done.returncode != 0:
        pytest.skip(f'cannot mount a tmpfs here: {done.stderr.strip()}')
    try:
        yield mount
    finally:
        subprocess.run(['umount', '-l', str(mount)], check=False)


def test_a_full_disk_closes_the_bag_with_what_was_written(tmp_path, small_disk):
    bag = small_disk / 'session'
    with ros_graph() as graph:
        node = graph.node('session_publisher')
        gaze = node.create_publisher(PointCloud2, GAZE_SAMPLES_TOPIC, GAZE_QOS)
        choice = node.create_publisher(String, CHOICE_TOPIC, EVENT_QOS)
        with running(MODULE, '-o', str(bag), log=tmp_path / 'record.log',
                     domain=graph.domain) as process:
            assert process.wait_for('recording into')
            wait_recording(graph, process, [GAZE_SAMPLES_TOPIC, CHOICE_TOPIC])
            choice.publish(String(data='first'))
            graph.spin_for(1.5)     # the choice is flushed to the file (FLUSH_PERIOD_S)
            # 1200 Hz gaze in big batches until the 3 MiB disk (1 MiB reserved) is full.
            points = np.random.default_rng(0).uniform(0, 1000, size=(2400, 2))
            sent = 0
            while process.process.poll() is None and sent < 3000:
                for message in gaze_messages(points, 100.0 + np.arange(2400) / 1200.0,
                                             chunk=2400):
                    gaze.publish(message)
                    sent += 1
                graph.spin_for(0.05)
            status = process.finish()
    output = process.output()
    assert status == 1, output
    problem = [line for line in output.splitlines() if 'failed (No space left on device)' in line]
    assert len(problem) == 1 and 'Traceback' not in output, output
    found, _ = read_bag(bag)
    assert [m.data for _, m in found['/choice']] == ['first']
    assert len(found['/gaze/samples']) > 0
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    counts = {t['topic_metadata']['name']: t['message_count']
              for t in meta['topics_with_message_count']}
    assert counts['/gaze/samples'] == len(found['/gaze/samples'])
    kept = sum(counts.values())
    assert f'the bag is closed with the {kept} messages written before' in problem[0]


def test_a_namespace_moves_the_recorded_topics_with_it(tmp_path):
    bag = tmp_path / 'left'
    with ros_graph() as graph:
        node = graph.add(Node, 'left_pipeline', namespace='/left')
        choice = node.create_publisher(String, CHOICE_TOPIC, EVENT_QOS)
        other = graph.node('other_pipeline').create_publisher(String, CHOICE_TOPIC, EVENT_QOS)
        with running(MODULE, '-o', str(bag), '--ros-args', '-r', '__ns:=/left',
                     log=tmp_path / 'record.log', domain=graph.domain) as process:
            assert process.wait_for('recording into')
            wait_recording(graph, process, ['left/' + CHOICE_TOPIC])
            choice.publish(String(data='left one'))
            other.publish(String(data='not this pipeline'))
            graph.spin_for(1.0)
            process.interrupt()
            assert process.finish() == 0, process.output()
    found, _ = read_bag(bag)
    assert [m.data for _, m in found['/left/choice']] == ['left one']
    assert '/choice' not in found


def test_the_actions_feedback_is_recorded_with_jazzys_type_and_hash(tmp_path):
    action = pytest.importorskip('nav2_msgs.action', reason='nav2_msgs is built with colcon '
                                 '(make .venv/.installed)')
    feedback_type = action.NavigateToPose.Impl.FeedbackMessage
    topic = 'navigate_to_pose/_action/feedback'
    bag = tmp_path / 'drive'
    with ros_graph() as graph:
        node = graph.node('navigator')
        publisher = node.create_publisher(feedback_type, topic, 10)
        with running(MODULE, '-o', str(bag), log=tmp_path / 'record.log',
                     domain=graph.domain) as process:
            assert process.wait_for('recording into')
            wait_recording(graph, process, [topic])
            message = feedback_type()
            message.feedback.current_pose.pose.position.x = 2.5
            message.feedback.distance_remaining = 1.25
            publisher.publish(message)
            graph.spin_for(1.0)
            process.interrupt()
            assert process.finish() == 0, process.output()
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    (entry,) = meta['topics_with_message_count']
    assert entry['topic_metadata']['type'] == 'nav2_msgs/action/NavigateToPose_FeedbackMessage'
    # Jazzy's hash of nav2 1.3's NavigateToPose_FeedbackMessage (ros_interfaces.md).
    assert entry['topic_metadata']['type_description_hash'] == (
        'RIHS01_9d1f6fa2eb975ce733b419ac2e97b134d8ff92b6478b6559feed9a50bdfd82b3')
    (mcap_file,) = bag.glob('*.mcap')
    with open(mcap_file, 'rb') as stream:
        reader = make_reader(stream, validate_crcs=True)
        schema = next(iter(reader.get_summary().schemas.values()))
        assert schema.name == 'nav2_msgs/action/NavigateToPose_FeedbackMessage'
        assert b'MSG: nav2_msgs/action/NavigateToPose_Feedback' in schema.data
    found, _ = read_bag(bag)
    (_, recorded), = found['/' + topic]
    assert recorded.feedback.current_pose.pose.position.x == 2.5
    assert recorded.feedback.distance_remaining == 1.25
