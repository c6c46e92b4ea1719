"""The arm planner on the bus: the /robotrial/plan_task service (layer 4).

`PlanningNode` plays MoveIt's move_group for the g2rViewer task. It holds no algorithm
of its own: each request goes to `robotrial.planning.task.TaskPlanner`, and a successful
trajectory is also published as the joint reference the simulators track.

| direction | name | type |
| --- | --- | --- |
| service | `/robotrial/plan_task` | robotrial_msgs/srv/PlanTask |
| in | `/joint_states` | sensor_msgs/JointState (the current joints when a request has none) |
| out | `/robotrial/joint_reference` | trajectory_msgs/JointTrajectory |
"""

from __future__ import annotations

import threading

from robotrial.model.robot import RobotModel
from robotrial.model.world import World
from robotrial.msgs.builtin_interfaces import Time
from robotrial.msgs.robotrial_msgs import PlanTask, PlanTaskRequest, PlanTaskResponse
from robotrial.msgs.sensor_msgs import JointState
from robotrial.msgs.trajectory_msgs import JointTrajectory
from robotrial.planning.task import TaskPlanner
from robotrial.ros.bus import Bus, Node

PLAN_TASK = "/robotrial/plan_task"
JOINT_REFERENCE = "/robotrial/joint_reference"


class PlanningNode(Node):
    """Answers PlanTask requests for `robot` (standing in `world`, if given)."""

    def __init__(
        self,
        bus: Bus,
        robot: RobotModel,
        world: World | None = None,
        name: str = "/robotrial_planner",
    ) -> None:
        super().__init__(bus, name)
        self.planner = TaskPlanner(robot, world)
        self._lock = threading.Lock()
        self._joints: JointState | None = None
        self.reference = self.create_publisher(JOINT_REFERENCE, JointTrajectory)
        self.create_subscription("/joint_states", JointState, self._on_joint_states)
        self.create_service(PLAN_TASK, PlanTask, self._on_request)

    def _on_joint_states(self, msg: JointState) -> None:
        self._joints = msg

    def _on_request(self, request: PlanTaskRequest) -> PlanTaskResponse:
        if not request.current_joints.position and self._joints is not None:
            request.current_joints = self._joints
        with self._lock:  # one plan at a time: the planner's checker buffers are shared
            response = self.planner.plan(request).response
        if response.success:
            response.trajectory.header.stamp = Time.now()
            self.reference.publish(response.trajectory)
        return response
