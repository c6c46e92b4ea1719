"""The planning node answers /robotrial/plan_task on the bus and publishes the reference."""

from __future__ import annotations

from robotrial.model import load_robot, load_world
from robotrial.msgs.geometry_msgs import Point, Pose, Quaternion, Vector3
from robotrial.msgs.robotrial_msgs import Box, PlanTaskRequest
from robotrial.msgs.sensor_msgs import JointState
from robotrial.ros.bus import Bus
from robotrial.ros.planning_node import JOINT_REFERENCE, PLAN_TASK, PlanningNode


def test_plan_task_service_on_the_bus() -> None:
    bus = Bus()
    node = PlanningNode(bus, load_robot("desk_arm"), load_world("desk"))
    got = []
    bus.subscribe(JOINT_REFERENCE, got.append)
    names = node.planner.joint_names
    bus.publish(
        "/joint_states", JointState(name=names, position=[-0.785, 0.8, 1.57, 0.0, 0.76, 0.0])
    )
    request = PlanTaskRequest(
        obstacles=[
            Box(id="C", size=Vector3(0.1, 0.1, 0.2), pose=Pose(Point(0.2, 0, 0.15), Quaternion()))
        ],
        ee_goal=Pose(Point(0.18, 0.2, 0.02), Quaternion(0, 0, 0, 0)),
    )
    response = bus.call(PLAN_TASK, request, timeout=60)
    assert response.success, response.message
    assert len(got) == 1 and got[0].joint_names == names
    assert got[0].points[-1].positions == response.goal_joints
    # a request the planner refuses is answered, not raised, and publishes nothing
    request.ee_goal.position.x = 2.0
    response = bus.call(PLAN_TASK, request, timeout=60)
    assert not response.success and "out of reach" in response.message
    assert len(got) == 1
    node.destroy()
