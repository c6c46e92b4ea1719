"""ROS message types as dataclasses, with rosbridge JSON and CBOR conversion (layer 0).

One module per ROS package (`sensor_msgs`, `geometry_msgs`, ...). Every type is a
dataclass built by `core.message`; importing this package registers them all, so
`lookup_message("sensor_msgs/LaserScan")` and `lookup_message("sensor_msgs/msg/LaserScan")`
both find `sensor_msgs.LaserScan`. Internal spelling is ROS 2 (see `core`).
"""

from robotrial.msgs import (
    builtin_interfaces,
    control_msgs,
    geometry_msgs,
    nav2_msgs,
    nav_msgs,
    robotrial_msgs,
    rosapi,
    rosgraph_msgs,
    sensor_msgs,
    std_msgs,
    std_srvs,
    tf2_msgs,
    tf2_web_republisher,
    trajectory_msgs,
    visualization_msgs,
)
from robotrial.msgs.core import (
    ACTIONS,
    DIALECTS,
    MESSAGES,
    SERVICES,
    ActionType,
    Dialect,
    Message,
    MessageError,
    ServiceType,
    full_definition,
    lookup_action,
    lookup_message,
    lookup_service,
    ros1_name,
    type_dialect,
    type_for_value,
)

__all__ = [
    "ACTIONS",
    "DIALECTS",
    "MESSAGES",
    "SERVICES",
    "ActionType",
    "Dialect",
    "Message",
    "MessageError",
    "ServiceType",
    "builtin_interfaces",
    "control_msgs",
    "full_definition",
    "geometry_msgs",
    "lookup_action",
    "lookup_message",
    "lookup_service",
    "nav2_msgs",
    "nav_msgs",
    "robotrial_msgs",
    "ros1_name",
    "rosapi",
    "rosgraph_msgs",
    "sensor_msgs",
    "std_msgs",
    "std_srvs",
    "tf2_msgs",
    "tf2_web_republisher",
    "trajectory_msgs",
    "type_dialect",
    "type_for_value",
    "visualization_msgs",
]
