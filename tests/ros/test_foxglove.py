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


def run_node(*args: str, timeout: float = 60.0) -> subprocess.CompletedProcess:
    """One of foxglove_node's scripts with Node (installed by `make setup`)."""
    node = shutil.which("node")
    if node is None or not (NODE_DIR / "node_modules" / "@foxglove" / "ws-protocol").is_dir():
        pytest.fail("node and tests/ros/foxglove_node/node_modules are needed: run `make setup`")
    return subprocess.run(
        [node, *args], cwd=NODE_DIR, capture_output=True, text=True, timeout=timeout
    )


LAYOUT = Path(__file__).parents[2] / "docs" / "foxglove" / "robotrial-layout.json"


@pytest.fixture(scope="module")
def live_sim() -> Iterator[tuple[Bus, FoxgloveBridge, list[Odometry], list]]:
    """The mobile manipulator in room A on a bus, at real time, with the bridge on a free port."""
    bus = Bus()
    robot = Simulation.create("room_a", "mobile_manipulator", options=SimOptions(cameras=False))
    node = SimNode(bus, robot)
    odom: list[Odometry] = []
    goals: list = []
    lock = threading.Lock()

    def keep(m: Odometry) -> None:
        with lock:
            odom.append(m)

    bus.subscribe("/odom", keep)
    bus.subscribe("/move_base_simple/goal", lambda m: goals.append(m))
    bridge = FoxgloveBridge(bus, port=0, robot=robot.robot)
    node.start(realtime=1.0)
    yield bus, bridge, odom, goals
    bridge.destroy()
    node.stop()
    node.destroy()
    robot.close()


def test_foxglove_client_sees_decodes_and_drives(live_sim) -> None:
    bus, bridge, odom, goals = live_sim
    start = odom[-1].pose.pose.position if odom else None
    proc = run_node("client.mjs", bridge.url, "3")
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

    assert len(goals) == 1 and goals[0].header.frame_id == "map"
    assert (goals[0].pose.position.x, goals[0].pose.position.y) == (1.5, -0.5)
    assert bus.topic_type("/move_base_simple/goal") == "geometry_msgs/msg/PoseStamped"
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


def test_foxglove_access_follows_the_rosbridge_rules() -> None:
    """A page from another site is refused (it could drive the robot); with a token, only
    a URL carrying it gets in; a client without an Origin gets the protocol's greeting."""
    import asyncio

    from websockets.asyncio.client import connect
    from websockets.exceptions import InvalidStatus

    from robotrial.ros.rosbridge.access import Access

    bus = Bus()
    open_bridge = FoxgloveBridge(bus, port=0)
    locked = FoxgloveBridge(bus, port=0, access=Access.create(token="s3cret-token"))

    async def status(url: str, origin: str | None = None) -> int | str:
        try:
            async with connect(url, subprotocols=["foxglove.websocket.v1"], origin=origin) as ws:
                return json.loads(await ws.recv())["op"]
        except InvalidStatus as exc:
            return exc.response.status_code

    try:
        assert asyncio.run(status(open_bridge.url)) == "serverInfo"
        assert asyncio.run(status(open_bridge.url, "https://evil.example")) == 403
        assert asyncio.run(status(locked.url)) == 401
        assert asyncio.run(status(locked.url + "/?token=s3cret-token")) == "serverInfo"
    finally:
        open_bridge.destroy()
        locked.destroy()


def test_busy_port_is_a_clear_error() -> None:
    bus = Bus()
    first = FoxgloveBridge(bus, port=0)
    try:
        with pytest.raises(OSError, match=f"127.0.0.1:{first.port}"):
            FoxgloveBridge(bus, port=first.port)
        assert bus.nodes() == [first.name]
    finally:
        first.destroy()


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait_for_port(port: int, proc: subprocess.Popen, timeout: float = 30.0) -> None:
    """Return once something listens on `port` (the server opens it at start-up)."""
    import socket
    import time

    deadline = time.monotonic() + timeout
    while True:
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1).close()
            return
        except OSError:
            assert proc.poll() is None, "the server exited"
            assert time.monotonic() < deadline, f"nothing listens on {port} after {timeout} s"
            time.sleep(0.1)


def test_serve_offers_foxglove_with_the_live_platform(tmp_path: Path) -> None:
    """`robotrial serve --foxglove-port` with a mobile robot: the Foxglove client sees the
    live platform's topics (SLAM's /map, the planner's /plan) next to the simulator's."""
    import sys

    web, fox = _free_port(), _free_port()
    command = [Path(sys.executable).with_name("robotrial"), "serve", "--port", str(web)]
    command += ["--foxglove-port", str(fox), "--robot", "mobile_manipulator", "--world", "room_a"]
    errors = (tmp_path / "serve.log").open("w")
    server = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=errors, text=True)
    try:
        line = server.stdout.readline() if server.stdout else ""
        assert f"Foxglove at ws://127.0.0.1:{fox}/" in line, line
        _wait_for_port(fox, server)
        proc = run_node("client.mjs", f"ws://127.0.0.1:{fox}", "1")
        assert proc.returncode == 0, proc.stderr + (tmp_path / "serve.log").read_text()
        r = json.loads(proc.stdout)
    finally:
        server.terminate()
        server.wait(10)
        errors.close()
    for topic in ("/map", "/plan", "/move_base_simple/goal", "/robot_description", "/tf"):
        assert r["channels"][topic]["schemaEncoding"] == "ros2msg", topic
    assert r["decoded"]["/robot_description"]["links"] > 5
    assert r["decoded"]["/scan"]["ranges"] > 100

    # The shipped layout only names topics this server offers.
    layout = json.loads(LAYOUT.read_text())["configById"]
    named = set(layout["3D!robotrial"]["topics"]) | {layout["Teleop!robotrial"]["topic"]}
    named.add(layout["Image!robotrial"]["imageMode"]["imageTopic"])
    assert named <= set(r["channels"]), named - set(r["channels"])


def test_3d_panel_fetches_the_robots_package_meshes(tmp_path: Path) -> None:
    """A URDF's package:// mesh comes through the protocol's asset fetch; another file of
    the same package does not (only the robot's meshes are served)."""
    import trimesh

    from robotrial.model.urdf import load_urdf

    pkg = tmp_path / "fg_robot"
    (pkg / "meshes").mkdir(parents=True)
    (pkg / "package.xml").write_text("<package><name>fg_robot</name></package>")
    trimesh.creation.box((0.2, 0.2, 0.2)).export(pkg / "meshes" / "body.stl")
    urdf = pkg / "robot.urdf"
    urdf.write_text(
        '<robot name="meshy"><link name="base"><visual><geometry>'
        '<mesh filename="package://fg_robot/meshes/body.stl"/></geometry></visual>'
        "</link></robot>"
    )
    robot = load_urdf(urdf)
    bridge = FoxgloveBridge(Bus(), port=0, robot=robot)
    good, other = "package://fg_robot/meshes/body.stl", "package://fg_robot/robot.urdf"
    try:
        proc = run_node("fetch.mjs", bridge.url, good, other, "package://nowhere/x.stl", timeout=30)
    finally:
        bridge.destroy()
    assert proc.returncode == 0, proc.stderr
    r = json.loads(proc.stdout)
    assert "assets" in r["capabilities"]
    assert r[good] == {"status": "ok", "bytes": (pkg / "meshes" / "body.stl").stat().st_size}
    assert r[other]["status"] == "error" and "not a mesh" in r[other]["error"]
    assert r["package://nowhere/x.stl"]["status"] == "error"


def test_foxglove_client_calls_a_bus_service() -> None:
    """A service on the bus is offered with ros2msg schemas; calls in CDR and JSON get the
    handler's answer, a request that does not decode gets a failure naming the service."""
    from robotrial.msgs.std_srvs import SetBool

    bus = Bus()
    seen: list[bool] = []

    def toggle(req: SetBool.Request) -> SetBool.Response:
        seen.append(req.data)
        return SetBool.Response(success=req.data, message=f"lamp {'on' if req.data else 'off'}")

    server = bus.advertise_service("/lamp/set", SetBool, toggle)
    bridge = FoxgloveBridge(bus, port=0)
    try:
        proc = run_node("call.mjs", bridge.url, "/lamp/set", '{"data": true}', timeout=30)
    finally:
        bridge.destroy()
        server.close()
    assert proc.returncode == 0, proc.stderr
    r = json.loads(proc.stdout)
    assert "services" in r["capabilities"]
    assert r["type"] == "std_srvs/srv/SetBool"
    assert r["requestSchemaName"] == "std_srvs/srv/SetBool_Request"
    assert r["1"] == {"success": True, "message": "lamp on"}
    assert r["2"] == {"success": True, "message": "lamp on"}
    assert "/lamp/set" in r["3"]["failure"]
    assert seen == [True, True]
