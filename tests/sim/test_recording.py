"""The sim node on the bus, and recordings: what is read back equals what was written."""

from __future__ import annotations

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from robotrial.msgs.geometry_msgs import Twist, Vector3
from robotrial.msgs.nav_msgs import Odometry
from robotrial.ros.bus import Bus
from robotrial.ros.playback import play, read_recording
from robotrial.ros.recorder import BusRecorder, Recorder
from robotrial.ros.sim_node import SimNode, cloud_points

TOPICS = [
    "/points",
    "/scan",
    "/odom",
    "/ground_truth",
    "/imu",
    "/joint_states",
    "/tf",
    "/tf_static",
]


@pytest.fixture(scope="module")
def recorded(boxroom, tmp_path_factory):
    """A 1 s drive recorded to MCAP and to a ROS 1 bag, with every message published."""
    folder = tmp_path_factory.mktemp("rec")
    bus = Bus()
    node = SimNode(bus, boxroom.make_sim())
    published: list[tuple[str, object]] = []
    for t in TOPICS:
        bus.subscribe(t, lambda m, t=t: published.append((t, m)))
    recorders = [Recorder(folder / "run.mcap"), Recorder(folder / "run.bag")]
    for r in recorders:
        BusRecorder(bus, r, TOPICS)
    bus.publish("/cmd_vel", Twist(linear=Vector3(x=0.5), angular=Vector3(z=0.3)))
    node.run(1.0)
    for r in recorders:
        r.close()
    return published, folder, node


def by_topic(items):
    out: dict[str, list] = {}
    for item in items:
        out.setdefault(item[0], []).append(item[1])
    return out


@pytest.mark.parametrize("name", ["run.mcap", "run.bag"])
def test_round_trip_reads_back_what_was_written(recorded, name):
    published, folder, _ = recorded
    back = by_topic(read_recording(folder / name))
    sent = by_topic(published)
    assert set(back) == set(TOPICS)
    for topic in TOPICS:
        assert back[topic] == sent[topic], topic


def test_sim_node_publishes_at_rates_and_obeys_cmd_vel(recorded):
    published, _, node = recorded
    sent = by_topic(published)
    assert len(sent["/points"]) == 11 and len(sent["/scan"]) == 11  # 10 Hz plus the first
    assert len(sent["/tf_static"]) == 1
    truth: Odometry = sent["/ground_truth"][-1]
    assert truth.header.frame_id == "world"
    assert truth.twist.twist.linear.x == pytest.approx(0.5, abs=0.05)
    odom: Odometry = sent["/odom"][-1]
    assert odom.header.frame_id == "odom" and odom.child_frame_id == "base_footprint"
    cloud = sent["/points"][-1]
    pts = cloud_points(cloud)
    assert pts.shape == (cloud.width, 3) and np.all(np.isfinite(pts))
    assert node.counts["/scan"] == 11


def test_mcap_decodes_with_an_independent_ros2_reader(recorded):
    _, folder, _ = recorded
    with open(folder / "run.mcap", "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        seen = {}
        for _, channel, _, decoded in reader.iter_decoded_messages():
            seen[channel.topic] = decoded
    assert seen["/scan"].angle_increment > 0
    assert seen["/tf_static"].transforms[0].header.frame_id
    assert seen["/points"].fields[0].name == "x"


def test_playback_feeds_the_bus(recorded):
    _, folder, _ = recorded
    bus = Bus()
    got = []
    bus.subscribe("/scan", got.append)
    n = play(folder / "run.bag", bus, topics=["/scan", "/odom"])
    assert len(got) == 11 and n == 11 + 51


def test_bad_recording_names_are_refused(tmp_path):
    with pytest.raises(ValueError, match=r"\.mcap \(ROS 2\) or \.bag"):
        Recorder(tmp_path / "run.txt")
    with pytest.raises(FileNotFoundError, match="no such recording"):
        list(read_recording(tmp_path / "missing.mcap"))


def test_joint_reference_topic_moves_the_arm_and_bad_ones_are_refused(boxroom):
    from robotrial.msgs.builtin_interfaces import Duration
    from robotrial.msgs.trajectory_msgs import JointTrajectory, JointTrajectoryPoint

    bus = Bus()
    node = SimNode(bus, boxroom.make_sim())
    points = [
        JointTrajectoryPoint(positions=[0.0, 0.0], time_from_start=Duration.from_sec(0.0)),
        JointTrajectoryPoint(positions=[0.5, -0.3], time_from_start=Duration.from_sec(1.0)),
    ]
    bus.publish(
        "/robotrial/joint_reference", JointTrajectory(joint_names=["j1", "j2"], points=points)
    )
    node.run(1.5)
    q = node.sim.joint_values()
    assert q["j1"] == pytest.approx(0.5, abs=0.01) and q["j2"] == pytest.approx(-0.3, abs=0.01)
    bad = JointTrajectory(joint_names=["elbow"], points=[JointTrajectoryPoint(positions=[0.1])])
    bus.publish("/robotrial/joint_reference", bad)
    assert node.rejected == ["joint reference names joints ['elbow'] this robot does not drive"]


def test_published_tf_tree_links_every_sensor_frame_to_odom(recorded):
    published, _, _ = recorded
    parent: dict[str, str] = {}
    for topic, msg in published:
        if topic in ("/tf", "/tf_static"):
            for t in msg.transforms:
                assert parent.setdefault(t.child_frame_id, t.header.frame_id) == t.header.frame_id
    frames = {m.header.frame_id for t, m in published if t in ("/points", "/scan", "/imu")}
    frames |= {m.child_frame_id for t, m in published if t == "/odom"}
    for frame in frames:
        seen, cur = set(), frame
        while cur != "odom":
            assert cur in parent and cur not in seen, f"{frame} does not reach odom"
            seen.add(cur)
            cur = parent[cur]
