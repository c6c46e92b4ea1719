"""Foxglove's own protocol client (@foxglove/ws-protocol, in Node) against the Foxglove
bridge over a live simulation: channels with ros2msg schemas, CDR decoded with the
schema, and a Twist published by the client that drives the robot."""

from __future__ import annotations

import json
import shutil
import subprocess
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from robotrial.msgs.nav_msgs import Odometry
from robotrial.ros.bus import Bus
from robotrial.ros.foxglove_bridge import FoxgloveBridge, decode_client_message
from robotrial.ros.sim_node import SimNode
from robotrial.sim.simulation import SimOptions, Simulation

NODE_DIR = Path(__file__).parent / "foxglove_node"


@pytest.fixture(scope="module")
def live_sim() -> Iterator[tuple[Bus, FoxgloveBridge, list[Odometry]]]:
    """The mobile manipulator in room A on a bus, at real time, with the bridge on a free port."""
    bus = Bus()
    robot = Simulation.create("room_a", "mobile_manipulator", options=SimOptions(cameras=False))
    node = SimNode(bus, robot)
    odom: list[Odometry] = []
    lock = threading.Lock()

    def keep(m: Odometry) -> None:
        with lock:
            odom.append(m)

    bus.subscribe("/odom", keep)
    bridge = FoxgloveBridge(bus, port=0, robot=robot.robot)
    node.start(realtime=1.0)
    yield bus, bridge, odom
    bridge.destroy()
    node.stop()
    node.destroy()
    robot.close()


def test_foxglove_client_sees_decodes_and_drives(live_sim) -> None:
    node = shutil.which("node")
    if node is None or not (NODE_DIR / "node_modules" / "@foxglove" / "ws-protocol").is_dir():
        pytest.fail("node and tests/ros/foxglove_node/node_modules are needed: run `make setup`")
    _, bridge, odom = live_sim
    start = odom[-1].pose.pose.position if odom else None
    proc = subprocess.run(
        [node, "client.mjs", bridge.url, "3"],
        cwd=NODE_DIR,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 0, proc.stderr
    r = json.loads(proc.stdout)

    assert "clientPublish" in r["server"]["capabilities"]
    ch = r["channels"]
    expected = {
        "/tf": "tf2_msgs/msg/TFMessage",
        "/tf_static": "tf2_msgs/msg/TFMessage",
        "/scan": "sensor_msgs/msg/LaserScan",
        "/points": "sensor_msgs/msg/PointCloud2",
        "/odom": "nav_msgs/msg/Odometry",
        "/robot_description": "std_msgs/msg/String",
        "/cmd_vel": "geometry_msgs/msg/Twist",
    }
    for topic, type_name in expected.items():
        assert ch[topic] == {
            "schemaName": type_name,
            "schemaEncoding": "ros2msg",
            "encoding": "cdr",
        }, topic

    scan = r["decoded"]["/scan"]
    assert scan["ranges"] > 100
    assert scan["finite"] > scan["ranges"] // 2  # walls all around in room A
    assert scan["angle_min"] < 0 < scan["angle_max"]
    desc = r["decoded"]["/robot_description"]
    assert desc["head"].startswith("<?xml") or desc["head"].startswith("<robot")
    assert desc["links"] > 5 and desc["length"] > 1000  # the whole mobile manipulator

    assert r["sent"] >= 10
    assert any("/cmd_vel" in s and "Twist" in s for s in r["statuses"]), r["statuses"]
    end = odom[-1]
    moved = (end.pose.pose.position.x - (start.x if start else 0.0)) ** 2 + (
        end.pose.pose.position.y - (start.y if start else 0.0)
    ) ** 2
    assert moved**0.5 > 0.3, f"the robot moved only {moved**0.5:.3f} m"
    assert end.pose.pose.orientation.z > 0.05  # it turned left, as the Twist asked


def test_bad_client_message_names_the_topic() -> None:
    from robotrial.msgs.geometry_msgs import Twist

    with pytest.raises(ValueError, match=r"/cmd_vel.*Twist"):
        decode_client_message(b"\x00\x01\x00\x00\x07", "cdr", Twist, "/cmd_vel")
    with pytest.raises(ValueError, match=r"/cmd_vel.*JSON"):
        decode_client_message(b"{nope", "json", Twist, "/cmd_vel")
    msg = decode_client_message(b'{"linear": {"x": 0.25}}', "json", Twist, "/cmd_vel")
    assert msg.linear.x == 0.25
