"""roslibjs's TF clients (TFClient over ROS 1 actionlib, ROS2TFClient over a ROS 2 action,
and the /republish_tfs service) get the transforms of a frame relative to a fixed frame
from robotrial's rosbridge server, as from tf2_web_republisher, while the robot moves."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

from robotrial.msgs.geometry_msgs import Quaternion, Transform, TransformStamped, Vector3
from robotrial.msgs.std_msgs import Header
from robotrial.msgs.tf2_msgs import TFMessage
from robotrial.ros.bus import Node

NODE_DIR = Path(__file__).parent / "node"
LIDAR_HEIGHT = 0.7


class MovingBase(Node):
    """odom -> base_link moving along x at 1 m/s (/tf); base_link -> lidar_link fixed."""

    def __init__(self, bus) -> None:
        super().__init__(bus, "/moving_base")
        self.tf = self.create_publisher("/tf", TFMessage)
        mount = TransformStamped(
            header=Header(frame_id="base_link"),
            child_frame_id="lidar_link",
            transform=Transform(translation=Vector3(z=LIDAR_HEIGHT), rotation=Quaternion()),
        )
        self.create_publisher("/tf_static", TFMessage, latched=True).publish(
            TFMessage(transforms=[mount])
        )
        self.x = 0.0
        self.create_timer(0.02, self.tick)

    def tick(self) -> None:
        self.x += 0.02
        base = TransformStamped(
            header=Header(frame_id="odom"),
            child_frame_id="base_link",
            transform=Transform(translation=Vector3(x=self.x), rotation=Quaternion()),
        )
        self.tf.publish(TFMessage(transforms=[base]))


def test_tf_clients_follow_the_robot(live) -> None:
    node = shutil.which("node")
    if node is None or not (NODE_DIR / "node_modules" / "roslib").is_dir():
        pytest.fail("node and tests/ros/node/node_modules are needed: run `make setup`")
    base = MovingBase(live.bus)
    try:
        proc = subprocess.run(
            [node, "tf.mjs", f"{live.url}/rosbridge"],
            cwd=NODE_DIR,
            capture_output=True,
            text=True,
            timeout=60,
        )
    finally:
        base.destroy()
    assert proc.returncode == 0, proc.stderr
    r = json.loads(proc.stdout)
    for first, second in (r["ros1"], r["ros2"]):
        assert first["translation"]["z"] == pytest.approx(LIDAR_HEIGHT)
        assert second["translation"]["x"] > first["translation"]["x"] > 0  # it moves
        assert first["rotation"]["w"] == pytest.approx(1.0)
    assert r["topic"].startswith("/tf_repub_")
    (t,) = r["array"]["transforms"]
    assert t["header"]["frame_id"] == "odom" and t["child_frame_id"] == "lidar_link"
    assert t["transform"]["translation"]["z"] == pytest.approx(LIDAR_HEIGHT)
