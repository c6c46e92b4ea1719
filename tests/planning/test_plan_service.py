"""The PlanTask service through a real rosbridge server and roslibpy: every error code,
a goal sent without its orientation, a planner per robot, and `robotrial rosbridge --robot`."""

from __future__ import annotations

import time

import numpy as np
import pytest
import roslibpy

from robotrial.model import load_robot, load_world
from robotrial.msgs.robotrial_msgs import PlanTaskResponse
from robotrial.ros.bus import Bus
from robotrial.ros.planning_node import PLAN_TASK, PlanningNode, robot_service
from tests.conftest import LOCAL, free_port
from tests.ros.conftest import start_server, stop_server

START = [-0.785, 0.80, 1.57, 0.0, 0.76, 0.0]  # the hand near (0.15, -0.15, 0.02)
JOINTS = ["joint1", "joint2", "joint3", "joint4", "joint5", "joint6"]
OBSTACLE_C = {
    "id": "C",
    "size": {"x": 0.1, "y": 0.1, "z": 0.2},
    "pose": {"position": {"x": 0.2, "y": 0.0, "z": 0.15}, "orientation": {"w": 1.0}},
}


def _request(goal=(0.18, 0.2, 0.02), obstacles=(OBSTACLE_C,), **extra) -> dict:
    """The page's request as rosbridge JSON; the goal without an orientation field."""
    x, y, z = goal
    return {
        "current_joints": {"name": JOINTS, "position": START},
        "obstacles": list(obstacles),
        "ee_goal": {"position": {"x": x, "y": y, "z": z}},
        **extra,
    }


@pytest.fixture(scope="module")
def plan_port() -> int:
    return free_port()


@pytest.fixture(scope="module")
def served(plan_port: int):
    """A standalone rosbridge server whose bus has the planning node for the desk arm
    (and, by name, any built-in robot), and a roslibpy client connected to it."""
    bus = Bus()
    node = PlanningNode(
        bus,
        load_robot("desk_arm"),
        load_world("desk"),
        robots=lambda name: (load_robot(name), None),
    )
    server = start_server(bus, plan_port)
    client = roslibpy.Ros(host="127.0.0.1", port=plan_port)
    client.run(timeout=10)
    yield client, node
    client.close()
    stop_server(server)
    node.destroy()


def _call(client, request: dict, service: str = PLAN_TASK) -> dict:
    srv = roslibpy.Service(client, service, "robotrial_msgs/PlanTask")
    return srv.call(roslibpy.ServiceRequest(request), timeout=120)


def test_success_without_orientation_is_a_position_goal(served) -> None:
    # rosbridge would fill the missing quaternion with the identity: "tool along the
    # base axes", out of reach for this goal; the service reads it as position only
    client, node = served
    resp = _call(client, _request())
    assert resp["success"], resp["message"]
    assert resp["error_code"] == PlanTaskResponse.SUCCESS
    assert resp["object_held"] is False
    tcp = node.planner.kin.link_pose(np.array(resp["goal_joints"]))[:3, 3]
    np.testing.assert_allclose(tcp, [0.18, 0.2, 0.02], atol=1e-3)
    # an explicit identity orientation is still a full pose goal, and unreachable here
    request = _request()
    request["ee_goal"]["orientation"] = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}
    resp = _call(client, request)
    assert resp["error_code"] == PlanTaskResponse.NO_IK_SOLUTION, resp["message"]


def test_object_held_is_decided_by_the_server(served) -> None:
    client, node = served
    tcp = node.planner.kin.link_pose(np.array(START))
    obj = {
        "id": "cup",
        "size": {"x": 0.03, "y": 0.03, "z": 0.05},
        "pose": {"position": dict(zip("xyz", tcp[:3, 3] + [0, 0, 0.03], strict=True))},
    }
    resp = _call(client, _request(goal=(0.18, 0.2, 0.06), object=obj))
    assert resp["success"] and resp["object_held"] is True, resp["message"]
    obj["pose"]["position"] = {"x": -0.2, "y": -0.2, "z": 0.025}  # on the table, far away
    resp = _call(client, _request(object=obj))
    assert resp["success"] and resp["object_held"] is False, resp["message"]


@pytest.mark.parametrize(
    ("request_args", "code", "words"),
    [
        ({"goal": (1.0, 0.2, 0.02)}, PlanTaskResponse.NO_IK_SOLUTION, "out of reach"),
        ({"goal": (0.2, 0.0, 0.15)}, PlanTaskResponse.GOAL_IN_COLLISION, "goal in collision"),
        (
            {
                "obstacles": [
                    {
                        "id": "crate",
                        "size": {"x": 0.2, "y": 0.2, "z": 0.2},
                        "pose": {"position": {"x": 0.15, "y": -0.15, "z": 0.05}},
                    }
                ]
            },
            PlanTaskResponse.START_STATE_IN_COLLISION,
            "crate",
        ),
        (
            {"obstacles": [{"id": "bad", "size": {"x": -0.1, "y": 0.1, "z": 0.1}}]},
            PlanTaskResponse.INVALID_GOAL_CONSTRAINTS,
            "obstacles[0].size",
        ),
        ({"planner": "nonsense"}, PlanTaskResponse.INVALID_GOAL_CONSTRAINTS, "unknown planner"),
        ({"planner": "rrt", "time_limit": 1e-6}, PlanTaskResponse.TIMED_OUT, "time limit"),
        ({"time_limit": -1}, PlanTaskResponse.INVALID_GOAL_CONSTRAINTS, "time_limit must be"),
        ({"time_limit": 3600}, PlanTaskResponse.INVALID_GOAL_CONSTRAINTS, "time_limit must be"),
        (
            {"obstacles": [{"id": "flat", "size": {"x": 0.0, "y": 0.0, "z": 0.0}}]},
            PlanTaskResponse.INVALID_GOAL_CONSTRAINTS,
            "obstacles[0].size has a zero edge",
        ),
        (
            {"obstacles": [{"size": {"x": 0.1, "y": 0.1, "z": 0.1}}] * 501},
            PlanTaskResponse.INVALID_GOAL_CONSTRAINTS,
            "at most 500",
        ),
        ({"goal": (float("nan"), 0.2, 0.02)}, PlanTaskResponse.INVALID_GOAL_CONSTRAINTS, "(nan, "),
    ],
)
def test_each_failure_has_its_code(served, request_args, code, words) -> None:
    client, _ = served
    args = dict(request_args)
    goal = args.pop("goal", (0.18, 0.2, 0.02))
    resp = _call(client, _request(goal, **args))
    assert not resp["success"]
    assert resp["error_code"] == code, resp["message"]
    assert words in resp["message"]


def test_messages_quote_what_was_sent_short_and_plain(served) -> None:
    client, _ = served
    resp = _call(client, _request(planner="x" * 1_000_000))
    assert resp["error_code"] == PlanTaskResponse.INVALID_GOAL_CONSTRAINTS
    assert "unknown planner 'xxxx" in resp["message"] and len(resp["message"]) < 300
    resp = _call(client, _request(goal=(float("inf"), 0.0, 0.0)))
    assert "np.float64" not in resp["message"] and "inf" in resp["message"]


def test_a_huge_request_does_not_hold_a_small_one(served, plan_port: int) -> None:
    """100,000 boxes (under the frame limit) are refused, and a desk request sent after
    them is answered first: the big one is read and refused off the event loop."""
    import asyncio
    import json

    import websockets

    url = f"ws://127.0.0.1:{plan_port}"
    box = {"size": {"x": 0.01, "y": 0.01, "z": 0.01}, "pose": {"position": {"x": 2.0}}}
    huge = {"op": "call_service", "id": "huge", "service": PLAN_TASK}
    huge["args"] = _request(obstacles=[box] * 100_000)
    small = {"op": "call_service", "id": "small", "service": PLAN_TASK, "args": _request()}

    async def send_both() -> list[dict]:
        answers: list[dict] = []

        async def ask(op: dict) -> None:
            async with websockets.connect(url, max_size=None) as ws:
                await ws.send(json.dumps(op))
                answers.append(json.loads(await asyncio.wait_for(ws.recv(), 120)))

        first = asyncio.ensure_future(ask(huge))
        await asyncio.sleep(0.05)  # the huge frame is on its way first
        await asyncio.gather(first, ask(small))
        return answers

    answers = asyncio.run(send_both())
    assert [a["id"] for a in answers] == ["small", "huge"]
    assert answers[0]["values"]["success"], answers[0]["values"]["message"]
    refused = answers[1]["values"]
    assert refused["error_code"] == PlanTaskResponse.INVALID_GOAL_CONSTRAINTS
    assert "100000 boxes" in refused["message"]


def test_a_robot_that_cannot_be_loaded_is_a_planning_failure(served) -> None:
    client, node = served
    node._robots = lambda name: (load_robot(name), None)
    resp = _call(client, _request(), node.add_robot("no_such_robot"))
    assert not resp["success"]
    assert resp["error_code"] == PlanTaskResponse.PLANNING_FAILED
    assert "no_such_robot" in resp["message"]


@pytest.mark.slow
def test_a_planner_per_robot_built_on_first_use(served) -> None:
    client, node = served
    node._robots = lambda name: (load_robot(name), None)
    service = node.add_robot("manipulator_h")
    assert service == robot_service("manipulator_h") == "/robotrial/robots/manipulator_h/plan_task"
    assert "manipulator_h" not in node._planners
    resp = _call(
        client,
        {"current_joints": {"position": [0.0] * 6}, "ee_goal": {"position": {"x": 0.3, "z": 0.3}}},
        service,
    )
    assert resp["success"], resp["message"]
    assert resp["trajectory"]["joint_names"] == node.planner_for("manipulator_h").joint_names
    assert "manipulator_h" in node._planners


def test_server_says_while_the_planner_compiles_and_offers_every_arm() -> None:
    from fastapi.testclient import TestClient

    from robotrial.app.server import create_app

    app = create_app(bus=Bus(), planner=True, warm=True)
    with TestClient(app, base_url=LOCAL) as client:
        body = client.get("/api/config").json()
        assert body["planner"] in ("compiling", "ready")
        deadline = time.monotonic() + 120
        while body["planner"] != "ready" and time.monotonic() < deadline:
            time.sleep(0.1)
            body = client.get("/api/config").json()
        assert body["planner"] == "ready"
        assert body["plan_services"]["manipulator_h"] == "/robotrial/robots/manipulator_h/plan_task"
        assert "husky" not in body["plan_services"]  # a mobile base has no arm to plan for
    assert (
        TestClient(create_app(warm=False), base_url=LOCAL).get("/api/config").json()["planner"]
        is None
    )


def test_warm_keeps_the_robot_model_for_a_fresh_process(tmp_path, monkeypatch) -> None:
    from robotrial.cli import main
    from robotrial.kinematics.chain import Kinematics
    from robotrial.planning.task import TaskPlanner, robot_spheres

    monkeypatch.setenv("ROBOTRIAL_CACHE", str(tmp_path))
    assert main(["warm", "--robot", "desk_arm"]) == 0
    kept = list((tmp_path / "robot-spheres").glob("*.pickle"))
    assert len(kept) == 1
    arm = load_robot("desk_arm")
    planner = TaskPlanner(arm)  # the same robot and joints: read back, nothing added
    assert planner.spheres.disabled and len(planner.spheres.bodies) > 3
    assert len(list((tmp_path / "robot-spheres").glob("*.pickle"))) == 1
    # a changed robot is not answered from the kept file
    lighter = arm.with_changes(name="desk_arm_copy")
    robot_spheres(Kinematics(lighter))
    assert len(list((tmp_path / "robot-spheres").glob("*.pickle"))) == 2
