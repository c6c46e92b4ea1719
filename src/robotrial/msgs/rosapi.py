"""rosapi_msgs: the services ROS tools call to discover a system (ROS 1 package `rosapi`).

roslibjs, roslibpy and Foxglove ask these to list topics, services, nodes and types.
"""

from __future__ import annotations

from typing import Any

from robotrial.msgs.builtin_interfaces import Time
from robotrial.msgs.core import (
    Message,
    ServiceType,
    bool_,
    int8,
    int32,
    message,
    service,
    string,
)


@message("rosapi_msgs/msg/TypeDef")
class TypeDef(Message):
    """One message type as rosapi describes it; `fieldarraylen` is -1 for a scalar,
    0 for an unbounded array and n for a fixed one."""

    type: string
    fieldnames: list[string]
    fieldtypes: list[string]
    fieldarraylen: list[int32]
    examples: list[string]
    constnames: list[string]
    constvalues: list[string]


def _srv(name: str, request: dict[str, Any], response: dict[str, Any]) -> ServiceType:
    def make(suffix: str, fields: dict[str, Any]) -> type[Message]:
        cls = type(f"{name}{suffix}", (Message,), {"__annotations__": dict(fields)})
        cls.__module__ = __name__
        return message(f"rosapi_msgs/srv/{name}_{suffix}")(cls)

    return service(f"rosapi_msgs/srv/{name}", make("Request", request), make("Response", response))


Topics = _srv("Topics", {}, {"topics": list[string], "types": list[string]})
TopicsForType = _srv("TopicsForType", {"type": string}, {"topics": list[string]})
TopicsAndRawTypes = _srv(
    "TopicsAndRawTypes",
    {},
    {"topics": list[string], "types": list[string], "typedefs_full_text": list[string]},
)
TopicType = _srv("TopicType", {"topic": string}, {"type": string})
Services = _srv("Services", {}, {"services": list[string]})
ServicesForType = _srv("ServicesForType", {"type": string}, {"services": list[string]})
ServiceType_ = _srv("ServiceType", {"service": string}, {"type": string})
Nodes = _srv("Nodes", {}, {"nodes": list[string]})
NodeDetails = _srv(
    "NodeDetails",
    {"node": string},
    {"subscribing": list[string], "publishing": list[string], "services": list[string]},
)
Publishers = _srv("Publishers", {"topic": string}, {"publishers": list[string]})
Subscribers = _srv("Subscribers", {"topic": string}, {"subscribers": list[string]})
ServiceProviders = _srv("ServiceProviders", {"service": string}, {"providers": list[string]})
ServiceNode = _srv("ServiceNode", {"service": string}, {"node": string})
MessageDetails = _srv("MessageDetails", {"type": string}, {"typedefs": list[TypeDef]})
ServiceRequestDetails = _srv("ServiceRequestDetails", {"type": string}, {"typedefs": list[TypeDef]})
ServiceResponseDetails = _srv(
    "ServiceResponseDetails", {"type": string}, {"typedefs": list[TypeDef]}
)
# ROS 2 rosapi adds `successful` and `reason` to the parameter answers; roslibjs reads them.
_OUTCOME = {"successful": bool_, "reason": string}
GetParam = _srv(
    "GetParam", {"name": string, "default_value": string}, {"value": string, **_OUTCOME}
)
SetParam = _srv("SetParam", {"name": string, "value": string}, _OUTCOME)
HasParam = _srv("HasParam", {"name": string}, {"exists": bool_})
DeleteParam = _srv("DeleteParam", {"name": string}, _OUTCOME)
GetParamNames = _srv("GetParamNames", {}, {"names": list[string]})
GetActionServers = _srv("GetActionServers", {}, {"action_servers": list[string]})
GetTime = _srv("GetTime", {}, {"time": Time})
GetROSVersion = _srv("GetROSVersion", {}, {"version": int8, "distro": string})
