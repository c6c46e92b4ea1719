"""The live platform behind the page's live view (layer 5): for a mobile robot in a room,
the simulator node and the SLAM node run on the server's bus, paced to real time, so
rosbridge clients (the page, roslibpy, Foxglove) see `/tf`, `/scan`, `/odom`, `/map`
and can drive through `/cmd_vel`.

Cameras are not rendered (they cost more than the rest together without a GPU); the
LiDAR, its 2D scan, odometry, joint states and TF are.
"""

from __future__ import annotations

import logging
import threading

from robotrial.app.catalog import robot_kind, world_kind
from robotrial.geometry import Pose
from robotrial.model.robot import RobotModel
from robotrial.model.world import World
from robotrial.ros.bus import Bus

log = logging.getLogger(__name__)


def runs_live(robot: RobotModel, world: World) -> bool:
    """A live platform runs for a mobile robot in a room (a world with walls)."""
    return robot_kind(robot) == "mobile" and world_kind(world) == "mobile"


class LivePlatform:
    """The simulator (and SLAM) on `bus` for `robot` in `world`, started at `spawn`.

    `start()` builds the simulation in a background thread (compiling the MuJoCo model
    takes a moment) and then steps it at `realtime` x real time; `stop()` ends it.
    The odom frame (and SLAM's map frame) starts at `spawn` in the world.
    """

    def __init__(
        self,
        bus: Bus,
        robot: RobotModel,
        world: World,
        spawn: Pose,
        *,
        slam: bool = True,
        realtime: float = 1.0,
        seed: int = 0,
    ) -> None:
        self.bus = bus
        self.robot = robot
        self.world = world
        self.spawn = spawn
        self.slam = slam
        self.realtime = realtime
        self.seed = seed
        self.error: str | None = None
        self._nodes: list = []
        self._lock = threading.Lock()
        self._stopped = False
        self._thread: threading.Thread | None = None

    def start(self) -> None:
        if self._thread is None:
            self._thread = threading.Thread(target=self._run, name="live-platform", daemon=True)
            self._thread.start()

    def _run(self) -> None:
        from robotrial.ros.sim_node import SimNode
        from robotrial.sim.simulation import SimOptions, Simulation

        try:
            sim = Simulation.create(
                self.world,
                self.robot,
                seed=self.seed,
                spawn=self.spawn,
                options=SimOptions(cameras=False),
            )
            with self._lock:
                if self._stopped:
                    return
                if self.slam:
                    from robotrial.ros.slam_node import SlamNode
                    from robotrial.slam.hector import HectorSlam

                    self._nodes.append(SlamNode(self.bus, HectorSlam()))
                node = SimNode(self.bus, sim)
                self._nodes.append(node)
                node.start(realtime=self.realtime)
        except Exception as exc:  # the server keeps serving; the page says why
            self.error = f"the live platform could not start: {exc}"
            log.exception("live platform")

    def stop(self) -> None:
        with self._lock:
            self._stopped = True
            nodes, self._nodes = self._nodes, []
        for node in reversed(nodes):
            node.destroy()
        if self._thread is not None:
            self._thread.join(timeout=10.0)
            self._thread = None
