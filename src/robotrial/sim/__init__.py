"""The MuJoCo world: physics loop, controllers and sensors, the Gazebo role (layer 2).

`Simulation.create("room_c", "mobile_manipulator")` builds a robot in a world; drive it
with `drive(v, w)` and `follow(JointReference)`, `advance(seconds)` and read the sensor
readings that fell due. `SimWorld` is the bare MuJoCo model, state and clock underneath.
"""

from robotrial.sim.controllers import (
    BaseController,
    DriveLimits,
    Gripper,
    JointController,
    JointReference,
)
from robotrial.sim.lidar import (
    Lidar,
    LidarPattern,
    PointCloud,
    Scan,
    ScanConfig,
    laserscan_from_points,
)
from robotrial.sim.odometry import OdometryNoise, WheelOdometry
from robotrial.sim.scene import Pacer, SimWorld
from robotrial.sim.simulation import Reading, SimOptions, Simulation, StreamSettings

__all__ = [
    "BaseController",
    "DriveLimits",
    "Gripper",
    "JointController",
    "JointReference",
    "Lidar",
    "LidarPattern",
    "OdometryNoise",
    "Pacer",
    "PointCloud",
    "Reading",
    "Scan",
    "ScanConfig",
    "SimOptions",
    "SimWorld",
    "Simulation",
    "StreamSettings",
    "WheelOdometry",
    "laserscan_from_points",
]
