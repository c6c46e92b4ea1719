"""rosbridge actions with roslibpy's ROS 2 ActionClient: /navigate_to_pose on the navigation
node and /arm_controller/follow_joint_trajectory on the simulator, both over the box
room's MuJoCo simulation paced at twice real time."""

from __future__ import annotations

import importlib.util
import json
import shutil
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import roslibpy
import websockets.sync.client

from robotrial.geometry import Pose as SimPose
from robotrial.msgs.geometry_msgs import Pose, PoseWithCovariance, PoseWithCovarianceStamped
from robotrial.msgs.nav_msgs import MapMetaData, OccupancyGrid
from robotrial.msgs.std_msgs import Header
from robotrial.nav.costmap import Footprint
from robotrial.ros.bus import Bus
from robotrial.ros.nav_node import NavNode
from robotrial.ros.sim_node import SimNode

from .conftest import start_server, stop_server

NAV = ("/navigate_to_pose", "nav2_msgs/action/NavigateToPose")
ARM = ("/arm_controller/follow_joint_trajectory", "control_msgs/action/FollowJointTrajectory")
START = (-1.5, 0.0, 0.0)
PACE = 2.0  # the simulation's speed, times real time


def _boxroom():
    path = Path(__file__).parents[1] / "sim" / "conftest.py"
    spec = importlib.util.spec_from_file_location("boxroom_conftest", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


BOXROOM = _boxroom()


def room_map(res: float = 0.05) -> OccupancyGrid:
    """The box room's walls as a map centred on the world origin."""
    hx, hy = BOXROOM.HALF_X + 0.1, BOXROOM.HALF_Y + 0.1
    w, h = round(2 * hx / res), round(2 * hy / res)
    grid = np.zeros((h, w), dtype=np.int8)
    grid[:2, :] = grid[-2:, :] = grid[:, :2] = grid[:, -2:] = 100
    info = MapMetaData(resolution=res, width=w, height=h, origin=Pose.planar(-hx, -hy, 0.0))
    return OccupancyGrid(header=Header(frame_id="map"), info=info, data=grid.ravel().tolist())


class Stack:
    """A bus with the simulator, the navigation node and a rosbridge server."""

    def __init__(self, port: int) -> None:
        self.bus = Bus()
        self.sim = BOXROOM.make_sim(spawn=SimPose.from_xy_yaw(*START))
        self.sim_node = SimNode(self.bus, self.sim)
        self.nav = NavNode(self.bus, Footprint(0.8, 0.5), laser_pose=(0.2, 0.0, 0.0))
        start = PoseWithCovarianceStamped(
            header=Header(frame_id="map"),
            pose=PoseWithCovariance(pose=Pose.planar(*START), covariance=[0.0001] * 36),
        )
        self.bus.publish("/initialpose", start, PoseWithCovarianceStamped)
        self.bus.publish("/map", room_map(), OccupancyGrid)
        self.cmd_vel: list = []
        self.bus.subscribe("/cmd_vel", self.cmd_vel.append, "geometry_msgs/msg/Twist")
        self.server = start_server(self.bus, port)
        # paced at twice real time: a cancel sent while the robot moves must arrive
        # before the goal is done, whatever the machine's load
        self.sim_node.start(realtime=PACE)
        self.ros = roslibpy.Ros(host="127.0.0.1", port=port)
        self.ros.run(timeout=10)

    def close(self) -> None:
        self.ros.close()
        self.sim_node.destroy()
        self.nav.destroy()
        stop_server(self.server)


@pytest.fixture
def stack(port):
    s = Stack(port)
    yield s
    s.close()


class Run:
    """One goal sent with roslibpy: its feedback and result."""

    def __init__(self, ros: roslibpy.Ros, action: tuple[str, str], goal: dict) -> None:
        self.client = roslibpy.ActionClient(ros, *action)
        self.feedback: list[dict] = []
        self.result: dict | None = None
        self.error = None
        self.done = threading.Event()
        self.id = self.client.send_goal(
            roslibpy.Goal(goal), self._on_result, self.feedback.append, self._on_error
        )

    def _on_result(self, result: dict) -> None:
        self.result = result
        self.done.set()

    def _on_error(self, err) -> None:
        self.error = err
        self.done.set()

    def wait(self, timeout: float = 25.0) -> dict:
        assert self.done.wait(timeout), "no action_result in time"
        assert self.error is None, self.error
        return self.result


def nav_goal(x: float, y: float) -> dict:
    return {"pose": {"header": {"frame_id": "map"}, "pose": Pose.planar(x, y, 0.0).to_dict()}}


def wait_for(cond, timeout: float = 20.0) -> None:
    deadline = time.monotonic() + timeout
    while not cond():
        assert time.monotonic() < deadline, "condition not met in time"
        time.sleep(0.02)


def test_navigate_to_pose_reaches_a_reachable_goal(stack) -> None:
    run = Run(stack.ros, NAV, nav_goal(0.5, 0.5))
    result = run.wait()
    assert result["status"] == roslibpy.core.GoalStatus.SUCCEEDED
    assert result["values"]["error_code"] == 0
    left = [f["distance_remaining"] for f in run.feedback]
    assert len(left) > 5
    assert left[-1] < left[0] - 1.0
    assert run.feedback[-1]["current_pose"]["header"]["frame_id"] == "map"
    x, y, _ = stack.sim.world.base_pose2d()
    assert np.hypot(x - 0.5, y - 0.5) < 0.3


def test_navigate_to_pose_aborts_an_unreachable_goal_with_a_reason(stack) -> None:
    result = Run(stack.ros, NAV, nav_goal(9.0, 0.0)).wait()
    assert result["status"] == roslibpy.core.GoalStatus.ABORTED
    assert result["values"]["error_code"] != 0
    assert result["values"]["error_msg"]


def test_navigate_to_pose_cancel_stops_the_robot(stack) -> None:
    run = Run(stack.ros, NAV, nav_goal(2.5, 0.0))
    wait_for(lambda: len(run.feedback) > 3 and stack.cmd_vel and stack.cmd_vel[-1].linear.x > 0)
    run.client.cancel_goal(run.id)
    result = run.wait()
    assert result["status"] == roslibpy.core.GoalStatus.CANCELED
    last = stack.cmd_vel[-1]
    assert (last.linear.x, last.angular.z) == (0.0, 0.0)
    x0 = stack.sim.world.base_pose2d()[0]
    time.sleep(0.5)
    assert stack.sim.world.base_pose2d()[0] == pytest.approx(x0, abs=0.05)


def arm_goal(names: list[str], points: list[tuple[list[float], float]]) -> dict:
    return {
        "trajectory": {
            "joint_names": names,
            "points": [
                {"positions": q, "time_from_start": {"sec": int(t), "nanosec": int(t % 1 * 1e9)}}
                for q, t in points
            ],
        }
    }


def test_follow_joint_trajectory_reaches_the_last_point(stack) -> None:
    run = Run(stack.ros, ARM, arm_goal(["j1", "j2"], [([0.4, -0.2], 0.5), ([0.8, -0.5], 1.0)]))
    result = run.wait()
    assert result["status"] == roslibpy.core.GoalStatus.SUCCEEDED
    assert result["values"]["error_code"] == 0
    q = stack.sim.joint_values()
    assert q["j1"] == pytest.approx(0.8, abs=0.02)
    assert q["j2"] == pytest.approx(-0.5, abs=0.02)
    fb = run.feedback[len(run.feedback) // 2]
    assert fb["joint_names"] == ["j1", "j2"]
    err = np.subtract(fb["desired"]["positions"], fb["actual"]["positions"])
    assert np.allclose(err, fb["error"]["positions"])


def test_follow_joint_trajectory_rejects_unknown_joints_and_bad_times(stack) -> None:
    result = Run(stack.ros, ARM, arm_goal(["j1", "elbow"], [([0.1, 0.1], 1.0)])).wait()
    assert result["status"] == roslibpy.core.GoalStatus.ABORTED
    assert result["values"]["error_code"] == -2  # INVALID_JOINTS
    assert "elbow" in result["values"]["error_string"]
    bad = arm_goal(["j1"], [([0.1], 1.0), ([0.2], 1.0)])
    result = Run(stack.ros, ARM, bad).wait()
    assert result["values"]["error_code"] == -1  # INVALID_GOAL
    assert "increase" in result["values"]["error_string"]


def test_follow_joint_trajectory_cancel_holds_the_arm(stack) -> None:
    run = Run(stack.ros, ARM, arm_goal(["j1"], [([2.0], 4.0)]))
    wait_for(lambda: stack.sim.joint_values()["j1"] > 0.3)
    run.client.cancel_goal(run.id)
    result = run.wait()
    assert result["status"] == roslibpy.core.GoalStatus.CANCELED
    time.sleep(0.3)
    q = stack.sim.joint_values()["j1"]
    assert q < 1.5
    time.sleep(0.3)
    assert stack.sim.joint_values()["j1"] == pytest.approx(q, abs=0.02)


def test_malformed_send_action_goal_gets_a_status_and_the_connection_lives(stack) -> None:
    with websockets.sync.client.connect(f"ws://127.0.0.1:{stack.server.config.port}") as ws:
        ws.send(json.dumps({"op": "send_action_goal", "id": "g1", "args": {}}))
        status = json.loads(ws.recv(timeout=5))
        assert status["op"] == "status" and "'action'" in status["msg"]
        bad = {"op": "send_action_goal", "id": "g2", "action": ARM[0], "args": {"trajectory": 3}}
        ws.send(json.dumps(bad))
        replies = [json.loads(ws.recv(timeout=5)) for _ in range(2)]
        ops = {r["op"]: r for r in replies}
        assert ops["action_result"]["result"] is False
        assert "trajectory" in ops["status"]["msg"]
        ws.send(json.dumps({"op": "send_action_goal", "id": "g3", "action": "/nowhere"}))
        replies = {r["op"]: r for r in (json.loads(ws.recv(timeout=5)) for _ in range(2))}
        assert replies["action_result"]["result"] is False
        assert "/nowhere is not offered" in replies["status"]["msg"]
        ws.send(json.dumps({"op": "call_service", "id": "c", "service": "/rosapi/get_time"}))
        reply = json.loads(ws.recv(timeout=5))
        assert reply["op"] == "service_response" and reply["result"] is True


def test_rosapi_lists_the_actions_and_describes_their_goals(stack) -> None:
    srv = roslibpy.Service(stack.ros, "/rosapi/action_servers", "rosapi_msgs/srv/GetActionServers")
    names = srv.call(roslibpy.ServiceRequest(), timeout=5)["action_servers"]
    assert {NAV[0], ARM[0]} <= set(names)
    details = stack.ros.get_message_details("nav2_msgs/action/NavigateToPose_Goal")
    goal = {d["type"]: d for d in details["typedefs"]}["nav2_msgs/action/NavigateToPose_Goal"]
    assert goal["fieldnames"] == ["pose", "behavior_tree"]


def test_roslib_node_action_client(stack) -> None:
    node_dir = Path(__file__).parent / "node"
    node = shutil.which("node")
    if node is None or not (node_dir / "node_modules" / "roslib").is_dir():
        pytest.fail("node and tests/ros/node/node_modules are needed: run `make setup`")
    proc = subprocess.run(
        [node, "actions.mjs", f"ws://127.0.0.1:{stack.server.config.port}/"],
        cwd=node_dir,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 0, proc.stderr
    r = json.loads(proc.stdout)
    assert r["nav"]["result"]["error_code"] == 0
    assert len(r["nav"]["feedback"]) > 5
    # roslibjs hands a finished goal that did not succeed to the failed callback
    assert "aborted" in r["unknown"]["error"] and "wrist" in r["unknown"]["error"]
    assert '"error_code":-2' in r["unknown"]["error"]
    assert "canceled" in r["canceled"]["error"]
    assert len(r["canceled"]["feedback"]) >= 20
