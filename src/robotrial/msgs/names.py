"""The platform's ROS names (docs/ros.md) with their types, for nodes and the web client."""

from __future__ import annotations

# topic -> message type (ROS 2 spelling)
TOPICS: dict[str, str] = {
    "/robotrial/joint_reference": "trajectory_msgs/msg/JointTrajectory",
    "/joint_states": "sensor_msgs/msg/JointState",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/tf_static": "tf2_msgs/msg/TFMessage",
    "/points": "sensor_msgs/msg/PointCloud2",
    "/scan": "sensor_msgs/msg/LaserScan",
    "/odom": "nav_msgs/msg/Odometry",
    "/cmd_vel": "geometry_msgs/msg/Twist",
    "/gripper/command": "control_msgs/msg/GripperCommand",
    "/map": "nav_msgs/msg/OccupancyGrid",
    "/plan": "nav_msgs/msg/Path",
    "/local_plan": "nav_msgs/msg/Path",
    "/move_base_simple/goal": "geometry_msgs/msg/PoseStamped",
    "/initialpose": "geometry_msgs/msg/PoseWithCovarianceStamped",
    "/amcl_pose": "geometry_msgs/msg/PoseWithCovarianceStamped",
    "/move_base/local_costmap/footprint": "geometry_msgs/msg/PolygonStamped",
    "/robotrial/nav_status": "robotrial_msgs/msg/NavStatus",
}

# service -> service type
SERVICES: dict[str, str] = {
    "/robotrial/plan_task": "robotrial_msgs/srv/PlanTask",
}

# Topics whose last message a late subscriber receives at once (ROS 1 latched,
# ROS 2 transient-local durability).
LATCHED_TOPICS: frozenset[str] = frozenset(
    {"/tf_static", "/map", "/robotrial/nav_status", "/move_base/local_costmap/footprint"}
)
