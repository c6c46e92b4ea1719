"""The arm planner on the bus: the /robotrial/plan_task service (layer 4).

`PlanningNode` plays MoveIt's move_group for the g2rViewer task. It holds no algorithm
of its own: each request is converted from its ROS message to arrays and geometry,
answered by `robotrial.planning.task.TaskPlanner`, and the result converted back with a
MoveIt error code (`robotrial.ros.plan_task.answer`); a successful trajectory
is also published as the joint reference the simulators track. The node plans for any
robot of a server's list: one TaskPlanner per robot, built on its first request.

Every request has a budget: at most `plan_task.MAX_OBSTACLES` boxes, a time limit that bounds the
whole answer (a request still waiting for its robot's planner when its time is up is
answered with TIMED_OUT and never planned), and work that stops once the caller has gone.
Requests for different robots plan at the same time; the compiled planner releases the
GIL, so the server's event loop keeps answering meanwhile.

| direction | name | type |
| --- | --- | --- |
| service | `/robotrial/plan_task` | robotrial_msgs/srv/PlanTask |
| in | `/joint_states` | sensor_msgs/JointState (the current joints when a request has none) |
| out | `/robotrial/joint_reference` | trajectory_msgs/JointTrajectory |
"""

from __future__ import annotations

import logging
import re
import threading
import time
from collections.abc import Callable

from robotrial.model.robot import RobotModel
from robotrial.model.world import World
from robotrial.msgs.builtin_interfaces import Time
from robotrial.msgs.robotrial_msgs import PlanTask, PlanTaskRequest, PlanTaskResponse
from robotrial.msgs.sensor_msgs import JointState
from robotrial.msgs.trajectory_msgs import JointTrajectory
from robotrial.planning.task import TaskError, TaskPlanner, time_limit
from robotrial.ros.bus import Bus, Node, current_call
from robotrial.ros.plan_task import answer

PLAN_TASK = "/robotrial/plan_task"
JOINT_REFERENCE = "/robotrial/joint_reference"

log = logging.getLogger(__name__)


def robot_service(robot: str) -> str:
    """The PlanTask service for one robot of a server's list: `/robotrial/robots/NAME/plan_task`
    (characters a ROS name cannot hold become `_`)."""
    safe = re.sub(r"[^A-Za-z0-9_]", "_", robot)
    if not safe or not (safe[0].isalpha() or safe[0] == "_"):
        safe = "r_" + safe
    return f"/robotrial/robots/{safe}{PLAN_TASK.removeprefix('/robotrial')}"


class PlanningNode(Node):
    """Answers PlanTask requests for `robot` (standing in `world`, if given) at PLAN_TASK.

    With `robots(name) -> (robot model, world)`, `add_robot(name)` also offers
    `robot_service(name)` for another robot of the server's list; its TaskPlanner is built
    on the first request and kept. `robot` None: no PLAN_TASK, only the robots added.
    """

    def __init__(
        self,
        bus: Bus,
        robot: RobotModel | None,
        world: World | None = None,
        name: str = "/robotrial_planner",
        robots: Callable[[str], tuple[RobotModel, World | None]] | None = None,
    ) -> None:
        super().__init__(bus, name)
        self.planner = None if robot is None else TaskPlanner(robot, world)
        self._robots = robots
        self._planners: dict[str, TaskPlanner] = {}
        self._services: dict[str, str] = {}
        self._lock = threading.Lock()  # guards the dictionaries
        # one plan at a time per planner: a planner's checker buffers are shared
        self._busy: dict[int, threading.Lock] = {}
        self._joints: JointState | None = None
        self.reference = self.create_publisher(JOINT_REFERENCE, JointTrajectory)
        self.create_subscription("/joint_states", JointState, self._on_joint_states)
        if self.planner is not None:
            self.create_service(PLAN_TASK, PlanTask, self._on_request)

    def add_robot(self, robot: str) -> str:
        """Offer PlanTask for `robot` (a name `robots` knows); returns the service name."""
        if self._robots is None:
            raise ValueError("this planning node was given no robot list")
        if robot in self._services:
            return self._services[robot]
        service, n = robot_service(robot), 1
        while self.bus.service(service) is not None:  # another name spelled the same
            n += 1
            service = robot_service(f"{robot}_{n}")
        self.create_service(service, PlanTask, lambda req: self._on_robot_request(robot, req))
        self._services[robot] = service
        return service

    def services(self) -> dict[str, str]:
        """Robot name -> its PlanTask service, for every robot added."""
        return dict(self._services)

    def forget(self, robot: str, default: bool = False) -> None:
        """Drop `robot`'s TaskPlanner (its description changed): the next request builds
        one for what `robots` gives then. With `default`, `robot` is the one PLAN_TASK
        answers for, and its planner is built again now."""
        with self._lock:
            self._planners.pop(robot, None)
        if default and self._robots is not None:
            planner = TaskPlanner(*self._robots(robot))
            with self._lock:
                self.planner = planner

    def planner_for(self, robot: str) -> TaskPlanner:
        """The TaskPlanner of `robot`, built on first use."""
        with self._lock:
            planner = self._planners.get(robot)
            if planner is None:
                assert self._robots is not None
                model, world = self._robots(robot)
                planner = self._planners[robot] = TaskPlanner(model, world)
            return planner

    def _on_joint_states(self, msg: JointState) -> None:
        self._joints = msg

    def _on_request(self, request: PlanTaskRequest) -> PlanTaskResponse:
        if not request.current_joints.position and self._joints is not None:
            request.current_joints = self._joints
        assert self.planner is not None
        return self._answer(self.planner, request)

    def _on_robot_request(self, robot: str, request: PlanTaskRequest) -> PlanTaskResponse:
        try:
            planner = self.planner_for(robot)
        except Exception as exc:  # a robot that cannot be planned for is answered so
            return PlanTaskResponse(
                success=False,
                message=f"no planner for robot {robot!r}: {exc}",
                error_code=PlanTaskResponse.PLANNING_FAILED,
            )
        return self._answer(planner, request)

    def _answer(self, planner: TaskPlanner, request: PlanTaskRequest) -> PlanTaskResponse:
        call = current_call()
        abandoned = call.abandoned if call is not None else None
        arrived = time.monotonic()
        with self._lock:
            busy = self._busy.setdefault(id(planner), threading.Lock())
        try:
            limit = time_limit(request.time_limit)
        except TaskError:  # refused before any planning: no need to wait for the planner
            return answer(planner, request)[0]
        if not busy.acquire(timeout=-1 if limit is None else limit):
            return PlanTaskResponse(
                success=False,
                message=f"the planner for this robot was busy for the whole time limit "
                f"({limit:g} s); try again",
                error_code=PlanTaskResponse.TIMED_OUT,
            )
        if limit:  # the time spent waiting counts against the limit given
            left = limit - (time.monotonic() - arrived)
            if left <= 0:
                busy.release()
                return PlanTaskResponse(
                    success=False,
                    message=f"the time limit ran out before planning ({limit:g} s)",
                    error_code=PlanTaskResponse.TIMED_OUT,
                )
            request.time_limit = left
        try:
            response, _ = answer(planner, request, abandoned=abandoned)
        except Exception as exc:  # answered, so that the client is not left waiting
            log.exception("plan_task failed")
            response = PlanTaskResponse(
                success=False,
                message=f"planning failed: {exc}",
                error_code=PlanTaskResponse.PLANNING_FAILED,
            )
        finally:
            busy.release()
        if response.success:
            response.trajectory.header.stamp = Time.now()
            self.reference.publish(response.trajectory)
        return response
