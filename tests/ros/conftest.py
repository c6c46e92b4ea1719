"""A real rosbridge server (uvicorn, standalone app) on a free port, with a populated bus."""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from typing import Any

import pytest
import uvicorn

from robotrial.msgs.builtin_interfaces import Time
from robotrial.msgs.geometry_msgs import Pose
from robotrial.msgs.nav_msgs import MapMetaData, OccupancyGrid
from robotrial.msgs.robotrial_msgs import PlanTask
from robotrial.msgs.sensor_msgs import JointState
from robotrial.msgs.std_msgs import Header
from robotrial.msgs.trajectory_msgs import JointTrajectory, JointTrajectoryPoint
from robotrial.ros.bus import Bus, Node
from robotrial.ros.rosbridge.access import Access
from robotrial.ros.rosbridge.transport import standalone_app, uvicorn_config

MAP_W, MAP_H = 40, 30


class EchoPlanner(Node):
    """Answers /robotrial/plan_task with the current joints moved by +1 rad."""

    def __init__(self, bus: Bus) -> None:
        super().__init__(bus, "/planner")
        self.create_service("/robotrial/plan_task", PlanTask, self.plan)

    def plan(self, req: Any) -> Any:
        if not req.current_joints.name:
            return PlanTask.Response(success=False, message="no joints given")
        goal = [p + 1.0 for p in req.current_joints.position]
        points = [
            JointTrajectoryPoint(positions=list(req.current_joints.position)),
            JointTrajectoryPoint(positions=goal),
        ]
        traj = JointTrajectory(joint_names=list(req.current_joints.name), points=points)
        return PlanTask.Response(success=True, goal_joints=goal, trajectory=traj)


def make_map() -> OccupancyGrid:
    info = MapMetaData(resolution=0.05, width=MAP_W, height=MAP_H, origin=Pose())
    data = [(i % 7) * 10 - 1 if i % 7 else -1 for i in range(MAP_W * MAP_H)]
    return OccupancyGrid(header=Header(frame_id="map"), info=info, data=data)


@dataclass
class Live:
    bus: Bus
    port: int
    url: str
    cmd_vel: list = field(default_factory=list)
    map_size: tuple[int, int] = (MAP_W, MAP_H)


class JointStatePublisher(Node):
    """Publishes /joint_states at `rate` Hz from a timer thread."""

    def __init__(self, bus: Bus, rate: float = 50.0) -> None:
        super().__init__(bus, "/joint_state_publisher")
        self.pub = self.create_publisher("/joint_states", JointState)
        self.k = 0
        self.create_timer(1.0 / rate, self.tick)

    def tick(self) -> None:
        self.k += 1
        self.pub.publish(
            JointState(
                header=Header(stamp=Time.now()),
                name=["j1", "j2"],
                position=[0.5 * self.k, -0.25],
            )
        )


def start_server(bus: Bus, port: int, access: Access | None = None) -> uvicorn.Server:
    app = standalone_app(bus, access=access)
    server = uvicorn.Server(uvicorn_config(app, "127.0.0.1", port))
    thread = threading.Thread(target=server.run, daemon=True, name="uvicorn")
    thread.start()
    deadline = time.monotonic() + 10
    while not server.started:
        if time.monotonic() > deadline or not thread.is_alive():
            raise RuntimeError("the rosbridge server did not start")
        time.sleep(0.02)
    server._test_thread = thread  # type: ignore[attr-defined]
    return server


def stop_server(server: uvicorn.Server) -> None:
    server.should_exit = True
    server._test_thread.join(timeout=10)  # type: ignore[attr-defined]


@pytest.fixture
def live(port: int):
    """The standalone rosbridge server with a planner, a /joint_states publisher, a
    latched /map and a /cmd_vel recorder on its bus."""
    bus = Bus()
    nodes = [EchoPlanner(bus), JointStatePublisher(bus)]
    bus.publish("/map", make_map())
    rec = Live(bus, port, f"ws://127.0.0.1:{port}")
    bus.subscribe("/cmd_vel", rec.cmd_vel.append, "geometry_msgs/msg/Twist")
    server = start_server(bus, port)
    yield rec
    stop_server(server)
    for n in nodes:
        n.destroy()
