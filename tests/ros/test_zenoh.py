"""ROS 2 without a bridge: a ROS 2 client written elsewhere (PyPI's zenoh-ros2-sdk, which
speaks rmw_zenoh's wire format) against `ZenohBridge` over a live simulation. It lists
robotrial's topics and services, receives /scan, /odom and the latched /tf_static,
publishes /cmd_vel that drives the robot, and calls a service (rosapi's topic_type).
The SDK is given the message definitions from rosbags' ROS 2 Jazzy type store (not from
robotrial.msgs), so it never downloads them and hashes the types from those definitions:
the keys only meet when both sides hash alike."""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from robotrial.msgs.nav_msgs import Odometry
from robotrial.ros.bus import Bus
from robotrial.ros.rosbridge.rosapi import Rosapi
from robotrial.ros.sim_node import SimNode
from robotrial.ros.zenoh_bridge import ZenohBridge
from robotrial.sim.simulation import SimOptions, Simulation

TYPES = (
    "sensor_msgs/msg/LaserScan",
    "nav_msgs/msg/Odometry",
    "geometry_msgs/msg/Twist",
    "tf2_msgs/msg/TFMessage",
)
TOPIC_TYPE = "string topic\n---\nstring type\n"  # rosapi_msgs/srv/TopicType (ROS 2)


def _field(desc) -> str:
    from rosbags.interfaces import Nodetype

    kind, rest = desc
    if kind == Nodetype.BASE:
        name, bound = rest
        return f"{name}<={bound}" if bound else name
    if kind == Nodetype.NAME:
        pkg, _, name = rest.split("/")
        return f"{pkg}/{name}"
    inner, count = rest
    base = _field(inner)
    if kind == Nodetype.ARRAY:
        return f"{base}[{count}]"
    return f"{base}[<={count}]" if count else f"{base}[]"


def write_definitions(folder: Path) -> None:
    """`.msg` files of TYPES and what they contain, from rosbags' Jazzy type store."""
    from rosbags.interfaces import Nodetype
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    todo, done = list(TYPES), set()
    while todo:
        name = todo.pop()
        if name in done:
            continue
        done.add(name)
        consts, fields = store.fielddefs[name]
        lines = [f"{t} {n}={v}" for n, t, v in consts]
        for fname, desc in fields:
            lines.append(f"{_field(desc)} {fname}")
            inner = desc[1][0] if desc[0] in (Nodetype.ARRAY, Nodetype.SEQUENCE) else desc
            if inner[0] == Nodetype.NAME:
                todo.append(inner[1])
        pkg, kind, short = name.split("/")
        path = folder / pkg / kind / f"{short}.msg"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("\n".join(lines) + "\n")
    srv = folder / "rosapi_msgs" / "srv" / "TopicType.srv"
    srv.parent.mkdir(parents=True)
    srv.write_text(TOPIC_TYPE)


def free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def graph(tmp_path_factory) -> Iterator[tuple[Bus, int, list[Odometry]]]:
    """The mobile manipulator in room A at real time, the bridge as the Zenoh router on
    a free loopback port, and the SDK's registry pointed at local definitions."""
    from zenoh_ros2_sdk import get_registry

    folder = tmp_path_factory.mktemp("msgs")
    write_definitions(folder)
    get_registry(str(folder))
    bus = Bus()
    sim = Simulation.create("room_a", "mobile_manipulator", options=SimOptions(cameras=False))
    node = SimNode(bus, sim)
    rosapi = Rosapi(bus)
    truth: list[Odometry] = []
    bus.subscribe("/ground_truth", truth.append)
    port = free_port()
    bridge = ZenohBridge(bus, connect=[], listen=[f"tcp/127.0.0.1:{port}"], mode="router")
    node.start(realtime=1.0)
    yield bus, port, truth
    from zenoh_ros2_sdk import ZenohSession

    if ZenohSession._instance is not None:
        ZenohSession._instance.close()
    bridge.destroy()
    node.destroy()
    rosapi.destroy()
    sim.close()


def _wait(done, timeout: float = 20.0, what=lambda: "") -> None:
    deadline = time.monotonic() + timeout
    while not done():
        assert time.monotonic() < deadline, f"timed out: {what()}"
        time.sleep(0.05)


def test_sdk_lists_topics_and_services(graph):
    from zenoh_ros2_sdk import get_service_names_and_types, get_topic_names_and_types

    _, port, _ = graph
    topics = dict(get_topic_names_and_types(router_port=port, timeout=1.0))
    assert topics["/scan"] == ["sensor_msgs/msg/LaserScan"]
    assert topics["/odom"] == ["nav_msgs/msg/Odometry"]
    assert topics["/tf_static"] == ["tf2_msgs/msg/TFMessage"]
    assert topics["/cmd_vel"] == ["geometry_msgs/msg/Twist"]  # the simulator listens
    services = dict(get_service_names_and_types(router_port=port, timeout=1.0))
    assert services["/rosapi/topic_type"] == ["rosapi_msgs/srv/TopicType"]


def test_sdk_receives_scan_odom_and_latched_tf_static(graph):
    from zenoh_ros2_sdk import ROS2Subscriber
    from zenoh_ros2_sdk.qos import QosDurability, QosProfile

    _, port, _ = graph
    got: dict[str, list] = {"scan": [], "odom": [], "tf": []}
    subs = [
        ROS2Subscriber("/scan", TYPES[0], got["scan"].append, router_port=port),
        ROS2Subscriber("/odom", TYPES[1], got["odom"].append, router_port=port),
        ROS2Subscriber(
            "/tf_static",
            TYPES[3],
            got["tf"].append,
            router_port=port,
            qos=QosProfile(durability=QosDurability.TRANSIENT_LOCAL, history_depth=1),
        ),
    ]
    try:
        _wait(
            lambda: len(got["scan"]) >= 3 and len(got["odom"]) >= 3 and got["tf"],
            what=lambda: {k: len(v) for k, v in got.items()},
        )
    finally:
        for s in subs:
            s.close()
    scan = got["scan"][-1]
    assert scan.header.frame_id and len(scan.ranges) > 100
    stamp = scan.header.stamp.sec + scan.header.stamp.nanosec * 1e-9
    assert 0 < stamp < 10_000  # simulated time, not wall time
    assert got["odom"][-1].child_frame_id == "base_footprint"
    assert len(got["tf"][0].transforms) > 3


def test_sdk_cmd_vel_drives_the_robot_and_a_service_answers(graph):
    from zenoh_ros2_sdk import ROS2Publisher, ROS2ServiceClient, get_message_class

    _, port, truth = graph
    pub = ROS2Publisher("/cmd_vel", TYPES[2], router_port=port)
    Vector3 = get_message_class("geometry_msgs/msg/Vector3")
    start = truth[-1].pose.pose.position.x
    try:
        deadline = time.monotonic() + 20
        while truth[-1].pose.pose.position.x - start < 0.2:
            assert time.monotonic() < deadline, "the robot did not move"
            pub.publish(linear=Vector3(x=0.5, y=0.0, z=0.0), angular=Vector3(x=0.0, y=0.0, z=0.0))
            time.sleep(0.1)
        pub.publish(linear=Vector3(x=0.0, y=0.0, z=0.0), angular=Vector3(x=0.0, y=0.0, z=0.0))
    finally:
        pub.close()
    client = ROS2ServiceClient("/rosapi/topic_type", "rosapi_msgs/srv/TopicType", router_port=port)
    try:
        response = client.call(topic="/scan")
    finally:
        client.close()
    assert response.type == "sensor_msgs/msg/LaserScan"
