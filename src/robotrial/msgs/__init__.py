"""ROS message types as dataclasses, with rosbridge JSON and CBOR conversion (layer 0).

One module per ROS package (`sensor_msgs`, `geometry_msgs`, ...), imported on first use.
Every type is a dataclass built by `core.message`; a lookup by name loads them all, so
`lookup_message("sensor_msgs/LaserScan")` and `lookup_message("sensor_msgs/msg/LaserScan")`
both find `sensor_msgs.LaserScan`. Internal spelling is ROS 2 (see `core`).
"""

import importlib
from typing import Any

from robotrial.msgs.core import (
    DIALECTS,
    PACKAGES,
    ActionType,
    Dialect,
    Message,
    MessageError,
    ServiceType,
    full_definition,
    load_all,
    lookup_action,
    lookup_message,
    lookup_service,
    ros1_name,
    type_dialect,
    type_for_value,
)

_REGISTRIES = ("ACTIONS", "MESSAGES", "SERVICES")


def __getattr__(name: str) -> Any:
    """A package's module, imported on first use; the registries, complete."""
    if name in PACKAGES:
        return importlib.import_module(f"robotrial.msgs.{name}")
    if name in _REGISTRIES:
        load_all()
        return getattr(importlib.import_module("robotrial.msgs.core"), name)
    raise AttributeError(f"module 'robotrial.msgs' has no attribute {name!r}")


__all__ = [
    "ACTIONS",
    "DIALECTS",
    "MESSAGES",
    "PACKAGES",
    "SERVICES",
    "ActionType",
    "Dialect",
    "Message",
    "MessageError",
    "ServiceType",
    "full_definition",
    "load_all",
    "lookup_action",
    "lookup_message",
    "lookup_service",
    "ros1_name",
    "type_dialect",
    "type_for_value",
    *PACKAGES,
]
