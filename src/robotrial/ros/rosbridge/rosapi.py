"""The rosapi services on the bus: what ROS tools ask to discover the graph (layer 4).

roslibjs (`getTopics`, `getMessageDetails`, params), roslibpy (`get_topics`,
`get_services`, `get_param`) and Foxglove (`/rosapi/topics_and_raw_types`) call these
like on a real rosbridge. Parameters live in `Bus.params`; values travel as JSON text,
as rosapi does.
"""

from __future__ import annotations

import json
from typing import Any

from robotrial.msgs import Dialect, Message, full_definition, lookup_message, lookup_service
from robotrial.msgs import rosapi as api
from robotrial.msgs.builtin_interfaces import Time
from robotrial.msgs.core import FieldSpec, dependencies, ros1_name
from robotrial.ros.bus import Bus, Node


def _spell(name: str, dialect: Dialect) -> str:
    return ros1_name(name) if dialect == "ros1" else name


def _example(spec: FieldSpec) -> str:
    if spec.array is not None:
        return "[]"
    if spec.msg is not None:
        return "{}"
    return {"string": "", "bool": "False"}.get(spec.base, "0.0" if "float" in spec.base else "0")


def typedefs(cls: type[Message], dialect: Dialect) -> list[api.TypeDef]:
    """rosapi TypeDefs of `cls` and its nested types. Nested type names use the same
    spelling as the typedefs' own `type`, so roslibjs can resolve them."""
    out = []
    for c in dependencies(cls):
        if dialect == "ros1" and c.__ros1__.primitive:
            continue
        r1 = c.__ros1__
        names, types, lens, examples = [], [], [], []
        if dialect == "ros1":
            for k, (t, v) in r1.extra.items():
                names.append(k)
                types.append(t)
                lens.append(-1)
                examples.append(str(v))
        for s in c.__fields_spec__:
            if dialect == "ros1" and s.name in r1.drop:
                continue
            names.append(r1.rename.get(s.name, s.name) if dialect == "ros1" else s.name)
            if s.msg is None:
                types.append(s.base)
            elif dialect == "ros1" and s.msg.__ros1__.primitive:
                types.append(s.msg.__ros1__.primitive)
            else:
                types.append(_spell(s.msg.__ros_type__, dialect))
            lens.append(-1 if s.array is None else max(s.array, 0))
            examples.append(_example(s))
        out.append(
            api.TypeDef(
                type=_spell(c.__ros_type__, dialect),
                fieldnames=names,
                fieldtypes=types,
                fieldarraylen=lens,
                examples=examples,
                constnames=[n for n, _, _ in c.__constants__],
                constvalues=[str(v) for _, _, v in c.__constants__],
            )
        )
    return out


class Rosapi(Node):
    """Offers /rosapi/*; `dialect` decides how type names are spelled in answers."""

    def __init__(self, bus: Bus, dialect: Dialect = "ros2", name: str = "/rosapi") -> None:
        super().__init__(bus, name)
        self.dialect = dialect
        services: dict[str, tuple[Any, Any]] = {
            "topics": (api.Topics, self.topics),
            "topics_for_type": (api.TopicsForType, self.topics_for_type),
            "topics_and_raw_types": (api.TopicsAndRawTypes, self.topics_and_raw_types),
            "topic_type": (api.TopicType, self.topic_type),
            "services": (api.Services, self.services),
            "services_for_type": (api.ServicesForType, self.services_for_type),
            "service_type": (api.ServiceType_, self.service_type),
            "nodes": (api.Nodes, self.nodes),
            "node_details": (api.NodeDetails, self.node_details),
            "publishers": (api.Publishers, self.publishers),
            "subscribers": (api.Subscribers, self.subscribers),
            "service_providers": (api.ServiceProviders, self.service_providers),
            "service_node": (api.ServiceNode, self.service_node),
            "message_details": (api.MessageDetails, self.message_details),
            "service_request_details": (api.ServiceRequestDetails, self.service_request_details),
            "service_response_details": (
                api.ServiceResponseDetails,
                self.service_response_details,
            ),
            "get_param": (api.GetParam, self.get_param),
            "set_param": (api.SetParam, self.set_param),
            "has_param": (api.HasParam, self.has_param),
            "delete_param": (api.DeleteParam, self.delete_param),
            "get_param_names": (api.GetParamNames, self.get_param_names),
            "get_time": (api.GetTime, self.get_time),
            "action_servers": (api.GetActionServers, self.action_servers),
            "get_ros_version": (api.GetROSVersion, self.get_ros_version),
        }
        for short, (srv, handler) in services.items():
            self.create_service(f"/rosapi/{short}", srv, handler, threaded=False)

    def _type(self, name: str) -> str:
        return _spell(name, self.dialect) if "/" in name else name

    def topics(self, req: Any) -> Any:
        topics = self.bus.topics()
        return api.Topics.Response(
            topics=list(topics), types=[self._type(t) for t in topics.values()]
        )

    def topics_for_type(self, req: Any) -> Any:
        want = lookup_message(req.type)
        key = want.__ros_type__ if want else req.type
        return api.TopicsForType.Response(
            topics=[n for n, t in self.bus.topics().items() if t == key]
        )

    def topics_and_raw_types(self, req: Any) -> Any:
        topics = self.bus.topics()
        texts = []
        for t in topics.values():
            cls = lookup_message(t) if t else None
            texts.append(full_definition(cls, self.dialect) if cls else "")
        return api.TopicsAndRawTypes.Response(
            topics=list(topics),
            types=[self._type(t) for t in topics.values()],
            typedefs_full_text=texts,
        )

    def topic_type(self, req: Any) -> Any:
        return api.TopicType.Response(type=self._type(self.bus.topic_type(req.topic)))

    def services(self, req: Any) -> Any:
        return api.Services.Response(services=list(self.bus.services()))

    def services_for_type(self, req: Any) -> Any:
        want = lookup_service(req.type)
        key = want.name if want else req.type
        return api.ServicesForType.Response(
            services=[n for n, t in self.bus.services().items() if t == key]
        )

    def service_type(self, req: Any) -> Any:
        t = self.bus.services().get(req.service, "")
        return api.ServiceType_.Response(type=self._type(t))

    def nodes(self, req: Any) -> Any:
        return api.Nodes.Response(nodes=self.bus.nodes())

    def node_details(self, req: Any) -> Any:
        return api.NodeDetails.Response(**self.bus.node_details(req.node))

    def publishers(self, req: Any) -> Any:
        return api.Publishers.Response(publishers=self.bus.publishers(req.topic))

    def subscribers(self, req: Any) -> Any:
        return api.Subscribers.Response(subscribers=self.bus.subscribers(req.topic))

    def service_providers(self, req: Any) -> Any:
        s = self.bus.service(req.service)
        return api.ServiceProviders.Response(providers=[s.node] if s else [])

    def service_node(self, req: Any) -> Any:
        s = self.bus.service(req.service)
        return api.ServiceNode.Response(node=s.node if s else "")

    def _details(self, name: str) -> list[api.TypeDef]:
        cls = lookup_message(name)
        if cls is None:
            raise ValueError(f"message type {name!r} is not known to this server")
        return typedefs(cls, "ros2" if name.count("/") >= 2 else "ros1")

    def message_details(self, req: Any) -> Any:
        return api.MessageDetails.Response(typedefs=self._details(req.type))

    def _srv_details(self, name: str, part: str) -> list[api.TypeDef]:
        srv = lookup_service(name)
        if srv is None:
            raise ValueError(f"service type {name!r} is not known to this server")
        cls = srv.Request if part == "request" else srv.Response
        return typedefs(cls, "ros2" if name.count("/") >= 2 else "ros1")

    def service_request_details(self, req: Any) -> Any:
        return api.ServiceRequestDetails.Response(typedefs=self._srv_details(req.type, "request"))

    def service_response_details(self, req: Any) -> Any:
        return api.ServiceResponseDetails.Response(typedefs=self._srv_details(req.type, "response"))

    def get_param(self, req: Any) -> Any:
        if req.name in self.bus.params:
            value = json.dumps(self.bus.params[req.name])
            return api.GetParam.Response(value=value, successful=True)
        if req.default_value:
            return api.GetParam.Response(value=req.default_value, successful=True)
        return api.GetParam.Response(reason=f"parameter {req.name} is not set")

    def set_param(self, req: Any) -> Any:
        try:
            value = json.loads(req.value)
        except json.JSONDecodeError:
            value = req.value
        self.bus.params[req.name] = value
        return api.SetParam.Response(successful=True)

    def has_param(self, req: Any) -> Any:
        return api.HasParam.Response(exists=req.name in self.bus.params)

    def delete_param(self, req: Any) -> Any:
        if req.name not in self.bus.params:
            return api.DeleteParam.Response(reason=f"parameter {req.name} is not set")
        del self.bus.params[req.name]
        return api.DeleteParam.Response(successful=True)

    def get_param_names(self, req: Any) -> Any:
        return api.GetParamNames.Response(names=sorted(self.bus.params))

    def action_servers(self, req: Any) -> Any:
        """The actions offered on the bus (`robotrial.ros.actions`), as ROS 2 rosapi lists
        them; their types go through message_details as `pkg/action/Name_Goal` etc."""
        return api.GetActionServers.Response(action_servers=sorted(self.bus.actions))

    def get_time(self, req: Any) -> Any:
        """The bus's time: simulated time while a simulator runs, as rosapi answers
        under `use_sim_time`."""
        ns = self.bus.now_ns()
        return api.GetTime.Response(time=Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000))

    def get_ros_version(self, req: Any) -> Any:
        if self.dialect == "ros1":
            return api.GetROSVersion.Response(version=1, distro="noetic")
        return api.GetROSVersion.Response(version=2, distro="humble")
