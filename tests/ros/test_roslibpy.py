"""roslibpy 2.x (the Python rosbridge client) against the running server."""

from __future__ import annotations

import threading
import time

import pytest
import roslibpy

from robotrial.msgs.robotrial_msgs import PlanTask


def wait_for(cond, timeout: float = 5.0) -> None:
    deadline = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > deadline:
            raise AssertionError("condition not met in time")
        time.sleep(0.01)


@pytest.fixture
def ros(live):
    client = roslibpy.Ros(host="127.0.0.1", port=live.port)
    client.run(timeout=10)
    yield client
    client.close()


def test_discovery(ros, live) -> None:
    topics = ros.get_topics()
    assert {"/joint_states", "/map", "/cmd_vel"} <= set(topics)
    assert ros.get_topic_type("/map") == "nav_msgs/msg/OccupancyGrid"
    assert "/robotrial/plan_task" in ros.get_services()
    assert ros.get_service_type("/robotrial/plan_task") == "robotrial_msgs/srv/PlanTask"
    assert "/planner" in ros.get_nodes()
    details = ros.get_message_details("geometry_msgs/Pose")
    types = {d["type"]: d for d in details["typedefs"]}
    assert types["geometry_msgs/Pose"]["fieldnames"] == ["position", "orientation"]
    assert types["geometry_msgs/Quaternion"]["fieldtypes"] == ["float64"] * 4
    req = ros.get_service_request_details("robotrial_msgs/PlanTask")
    assert req["typedefs"][0]["fieldnames"][:3] == ["current_joints", "obstacles", "object"]


def test_plan_task_call(ros) -> None:
    service = roslibpy.Service(ros, "/robotrial/plan_task", "robotrial_msgs/PlanTask")
    request = {
        "current_joints": {
            "header": {"seq": 7, "stamp": {"secs": 1, "nsecs": 5}, "frame_id": "base"},
            "name": ["a", "b", "c"],
            "position": [0.0, 0.5, -0.5],
        },
        "ee_goal": {"position": {"x": 0.2}, "orientation": {"w": 0.0}},
        "time_limit": 2,
    }
    resp = service.call(roslibpy.ServiceRequest(request), timeout=5)
    assert resp["success"] is True
    assert resp["goal_joints"] == [1.0, 1.5, 0.5]
    assert resp["trajectory"]["points"][1]["positions"] == [1.0, 1.5, 0.5]
    # roslibpy sends no type with a call: the answer has the server's (ROS 2) spelling
    assert set(resp["trajectory"]["header"]["stamp"]) == {"sec", "nanosec"}

    failed = service.call(roslibpy.ServiceRequest({}), timeout=5)
    assert failed["success"] is False and failed["message"] == "no joints given"

    with pytest.raises(Exception, match="no field 'bogus'"):
        service.call(roslibpy.ServiceRequest({"bogus": 1}), timeout=5)


def test_subscribe_publish_and_latched(ros, live) -> None:
    got, maps = [], []
    joints = roslibpy.Topic(ros, "/joint_states", "sensor_msgs/msg/JointState", queue_length=10)
    joints.subscribe(got.append)
    grid = roslibpy.Topic(ros, "/map", "nav_msgs/OccupancyGrid")
    grid.subscribe(maps.append)
    wait_for(lambda: len(got) >= 5 and maps)
    joints.unsubscribe()
    assert got[0]["name"] == ["j1", "j2"]
    assert set(got[0]["header"]["stamp"]) == {"sec", "nanosec"}
    assert maps[0]["info"]["width"] == live.map_size[0]
    assert set(maps[0]["header"]["stamp"]) == {"secs", "nsecs"}  # asked as nav_msgs/X

    cmd = roslibpy.Topic(ros, "/cmd_vel", "geometry_msgs/Twist")
    cmd.advertise()
    cmd.publish(roslibpy.Message({"linear": {"x": 1.5}}))
    wait_for(lambda: live.cmd_vel)
    assert live.cmd_vel[0].linear.x == 1.5
    cmd.unadvertise()


def test_service_offered_by_roslibpy(ros, live) -> None:
    def handler(request, response):
        response["success"] = request["data"]
        response["message"] = "switched"
        return True

    service = roslibpy.Service(ros, "/gripper/enable", "std_srvs/SetBool")
    service.advertise(handler)
    wait_for(lambda: live.bus.service("/gripper/enable") is not None)
    answers = []
    callers = [
        threading.Thread(
            target=lambda: answers.append(live.bus.call("/gripper/enable", {"data": True}, 5))
        )
        for _ in range(4)
    ]
    for t in callers:
        t.start()
    for t in callers:
        t.join(10)
    assert [a.success for a in answers] == [True] * 4
    assert answers[0].message == "switched"
    service.unadvertise()
    wait_for(lambda: live.bus.service("/gripper/enable") is None)


def test_params(ros) -> None:
    p = roslibpy.Param(ros, "/max_speed")
    p.set(0.75, timeout=5)
    assert p.get(timeout=5) == 0.75
    assert "/max_speed" in ros.get_params()
    p.delete(timeout=5)
    assert "/max_speed" not in ros.get_params()


def test_typed_request_reaches_node(live) -> None:
    resp = live.bus.call(
        "/robotrial/plan_task",
        PlanTask.Request.from_dict({"current_joints": {"name": ["x"], "position": [2.0]}}),
    )
    assert resp.goal_joints == [3.0]


def test_connect_by_url_to_the_rosbridge_path(live) -> None:
    client = roslibpy.Ros(host=f"{live.url}/rosbridge")
    client.run(timeout=10)
    try:
        assert "/rosapi/topics" in client.get_services()
    finally:
        client.close()
