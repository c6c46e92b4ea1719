"""ROS 2 without a bridge: the bus on Zenoh, spoken as rmw_zenoh speaks it (layer 4).

ROS 2 nodes that run `RMW_IMPLEMENTATION=rmw_zenoh_cpp` (Jazzy and later) see robotrial's
nodes, topics and services as their own: `ros2 topic list`, `ros2 topic echo /scan`,
`ros2 topic pub /cmd_vel ...` and `ros2 service call` work with no bridge process. The
wire format followed is rmw_zenoh_cpp 0.2.10 (the Jazzy release, zenoh 1.x):

- data: key `<domain>/<topic without leading slash>/<pkg>::msg::dds_::<Name>_/<RIHS01 hash>`,
  payload the CDR bytes (little endian, with the 4-byte encapsulation header), and an
  attachment of sequence number (int64), source timestamp (int64 ns) and the 16-byte GID
  (zenoh-ext serialization: a length byte before the GID); transient-local topics
  (latched: /tf_static, /map, /robot_description) go out through an advanced publisher
  with a cache of their last message, which late subscribers query;
- services: a queryable on `<domain>/<service>/<pkg>::srv::dds_::<Name>_/<hash>`; a
  request's attachment names the client's sequence number and GID, echoed in the reply;
- discovery: liveliness tokens `@ros2_lv/<domain>/<zid>/<node id>/<entity id>/<NN|MP|MS|SS>/
  %/<namespace>/<node>[/<topic>/<type>/<hash>/<qos>]`, names with `/` written as `%`, the QoS
  as rmw_zenoh encodes it (fields equal to its defaults left empty);
- type hashes: REP-2011's RIHS01 of the type description, computed by rosbags from
  robotrial.msgs' definitions (a service's from its request, response and event types).

Each bus node becomes a ROS 2 node with its publishers, subscriptions and services. A
bus topic is sent to Zenoh only while a remote subscription for it exists (latched
topics always, for the cache); a remote publisher's messages on a topic of a type robotrial
knows are published on the bus. The bus is scanned for new topics and services every
`scan_period` s.
"""

from __future__ import annotations

import hashlib
import itertools
import logging
import struct
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from functools import cache
from typing import Any

from robotrial.msgs import Message, ServiceType, cdr, lookup_message, lookup_service
from robotrial.msgs.core import definition, dependencies
from robotrial.ros.bus import Bus, Node, Publisher, Subscription
from robotrial.ros.recorder import deserialize

log = logging.getLogger(__name__)

RMW_ZENOH_VERSION = "0.2.10"  # rmw_zenoh_cpp (ROS 2 Jazzy) whose wire format this follows
ADMIN_SPACE = "@ros2_lv"
DEFAULT_ROUTER = "tcp/127.0.0.1:7447"  # where rmw_zenohd listens
SERVICE_TIMEOUT = 120.0  # s a bus service may take to answer a Zenoh query
# rmw_zenoh's QoS defaults are reliable, volatile, keep last 42; a token leaves equal
# fields empty. Ours: keep last 10 (volatile) or 1 (transient local, durability 1).
QOS_VOLATILE = "::,10:,:,:,,"
QOS_TRANSIENT_LOCAL = ":1:,1:,:,:,,"
SERVICE_EVENT_INFO = (
    "uint8 event_type\nbuiltin_interfaces/Time stamp\nuint8[16] client_gid\nint64 sequence_number\n"
)


def mangle(name: str) -> str:
    """A ROS name inside a key expression: `/` becomes `%` (an empty name is `%`)."""
    return name.replace("/", "%") if name else "%"


def dds_name(type_name: str) -> str:
    """`pkg/msg/Name` as rmw_zenoh names it in keys: `pkg::msg::dds_::Name_`."""
    pkg, kind, name = type_name.split("/")
    return f"{pkg}::{kind}::dds_::{name}_"


def _normalized(name: str) -> str:
    """Undo rosbags' move of service and action parts under `.../msg/`."""
    for kind in ("srv", "action"):
        name = name.replace(f"/{kind}/msg/", f"/{kind}/")
    return name


def _rename(desc: Any) -> Any:
    if isinstance(desc, str):
        return _normalized(desc)
    if isinstance(desc, tuple | list):
        return type(desc)(_rename(d) for d in desc)
    return desc


def _store_types(text: str, name: str) -> dict:
    from rosbags.typesys import get_types_from_msg

    return {_normalized(k): _rename(v) for k, v in get_types_from_msg(text, name).items()}


def _message_types(cls: type[Message]) -> dict:
    types: dict = {}
    for c in dependencies(cls):
        types.update(_store_types(definition(c, "ros2"), c.__ros_type__))
    return types


def _hash(types: dict, name: str) -> str:
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.EMPTY)
    store.register(types)
    return store.hash_rihs01(name)


@cache
def message_hash(cls: type[Message]) -> str:
    """The RIHS01 type hash of a message type (REP-2011), as rosidl computes it."""
    return _hash(_message_types(cls), cls.__ros_type__)


@cache
def service_hash(srv: ServiceType) -> str:
    """The RIHS01 hash of a service type: the description of `pkg/srv/Name` with its
    request, response and event messages, as rosidl generates it."""
    from robotrial.msgs.builtin_interfaces import Time

    name = srv.name
    types = {**_message_types(srv.Request), **_message_types(srv.Response)}
    types.update(_message_types(Time))
    types.update(_store_types(SERVICE_EVENT_INFO, "service_msgs/msg/ServiceEventInfo"))
    event = (
        "service_msgs/ServiceEventInfo info\n"
        f"{srv.Request.__ros_type__}[<=1] request\n{srv.Response.__ros_type__}[<=1] response\n"
    )
    types.update(_store_types(event, f"{name}_Event"))
    whole = (
        f"{srv.Request.__ros_type__} request_message\n"
        f"{srv.Response.__ros_type__} response_message\n{name}_Event event_message\n"
    )
    types.update(_store_types(whole, name))
    return _hash(types, name)


def attachment(sequence: int, timestamp_ns: int, gid: bytes) -> bytes:
    """rmw_zenoh's attachment: int64 sequence number, int64 source timestamp, the GID."""
    return struct.pack("<qqB", sequence, timestamp_ns, len(gid)) + gid


def parse_attachment(data: bytes) -> tuple[int, int, bytes]:
    """(sequence number, source timestamp ns, GID) of an rmw_zenoh attachment."""
    seq, stamp, n = struct.unpack_from("<qqB", data)
    return seq, stamp, bytes(data[17 : 17 + n])


@dataclass(frozen=True)
class Endpoint:
    """One ROS 2 graph entity this bridge announces: kind MP, MS or SS on a bus node."""

    kind: str
    node: str
    name: str
    type_name: str
    type_hash: str
    latched: bool = False


@dataclass
class _Outgoing:
    """A bus topic sent to Zenoh: its publisher and (while someone listens) bus subscription."""

    topic: str
    cls: type[Message]
    publisher: Any
    gid: bytes
    latched: bool
    sequence: itertools.count = field(default_factory=lambda: itertools.count(1))
    bus_sub: Subscription | None = None


class ZenohBridge(Node):
    """The bus on Zenoh in rmw_zenoh's wire format (see the module's docstring).

    `connect`: Zenoh endpoints to join, by default the rmw_zenoh router on this machine;
    `listen`: endpoints to accept connections on (with `mode="router"` the bridge is the
    router ROS 2 nodes connect to, no rmw_zenohd needed). `domain_id`: ROS_DOMAIN_ID.
    ImportError (with the install command) without eclipse-zenoh; OSError when Zenoh
    cannot open.
    """

    def __init__(
        self,
        bus: Bus,
        *,
        connect: tuple[str, ...] | list[str] = (DEFAULT_ROUTER,),
        listen: tuple[str, ...] | list[str] = (),
        mode: str = "peer",
        domain_id: int = 0,
        scan_period: float = 0.5,
        name: str = "/zenoh_bridge",
    ) -> None:
        try:
            import zenoh
        except ImportError as exc:
            raise ImportError(
                "ROS 2 over Zenoh needs eclipse-zenoh: pip install 'robotrial[zenoh]'"
            ) from exc
        import json

        if mode not in ("peer", "router", "client"):
            raise ValueError(f"zenoh mode must be peer, router or client, got {mode!r}")
        super().__init__(bus, bus.unique_node_name(name))
        self._zenoh = zenoh
        self.domain_id = domain_id
        conf = zenoh.Config()
        conf.insert_json5("mode", json.dumps(mode))
        conf.insert_json5("connect/endpoints", json.dumps(list(connect)))
        conf.insert_json5("listen/endpoints", json.dumps(list(listen)))
        conf.insert_json5("scouting/multicast/enabled", "false")
        try:
            self.session = zenoh.open(conf)
        except Exception as exc:  # zenoh raises its own ZError
            super().destroy()
            raise OSError(f"Zenoh cannot open ({mode}, connect {connect}): {exc}") from None
        self.zid = str(self.session.zid())
        self._lock = threading.RLock()
        self._node_ids: dict[str, int] = {}
        self._entity_ids = itertools.count(1)
        self._node_tokens: dict[str, Any] = {}
        self._tokens: dict[Endpoint, Any] = {}
        self._outgoing: dict[str, _Outgoing] = {}
        self._queryables: dict[str, Any] = {}
        self._remote_subs: dict[str, set[str]] = {}  # topic -> remote MS token keys
        self._incoming: dict[str, tuple[Any, Publisher]] = {}  # data key -> (sub, bus pub)
        self._calls = ThreadPoolExecutor(max_workers=4, thread_name_prefix="zenoh-service")
        self._graph = self.session.liveliness().declare_subscriber(
            f"{ADMIN_SPACE}/{domain_id}/**", self._on_token, history=True
        )
        self.refresh()
        self.create_timer(scan_period, self.refresh)

    # --- what the bus offers ------------------------------------------------------------

    def _endpoints(self) -> set[Endpoint]:
        out: set[Endpoint] = set()
        for topic, type_name in self.bus.topics().items():
            cls = lookup_message(type_name) if type_name else None
            if cls is None:
                continue
            latched = self.bus.is_latched(topic)
            h = message_hash(cls)
            for node in self.bus.publishers(topic):
                if node != self.name:
                    out.add(Endpoint("MP", node, topic, cls.__ros_type__, h, latched))
            for node in self.bus.subscribers(topic):
                if node != self.name:
                    out.add(Endpoint("MS", node, topic, cls.__ros_type__, h))
        for service, type_name in self.bus.services().items():
            srv = lookup_service(type_name)
            server = self.bus.service(service)
            if srv is not None and server is not None:
                out.add(Endpoint("SS", server.node, service, srv.name, service_hash(srv)))
        return out

    def data_key(self, name: str, type_name: str, type_hash: str) -> str:
        return f"{self.domain_id}/{name.strip('/')}/{dds_name(type_name)}/{type_hash}"

    def _node_key(self, node: str) -> str:
        nid = self._node_ids.setdefault(node, len(self._node_ids) + 1)
        return f"{ADMIN_SPACE}/{self.domain_id}/{self.zid}/{nid}/{nid}/NN/%/%/{mangle(node[1:])}"

    def _token_key(self, ep: Endpoint, eid: int) -> str:
        nid = self._node_ids.setdefault(ep.node, len(self._node_ids) + 1)
        qos = QOS_TRANSIENT_LOCAL if ep.latched else QOS_VOLATILE
        return (
            f"{ADMIN_SPACE}/{self.domain_id}/{self.zid}/{nid}/{eid}/{ep.kind}/%/%/"
            f"{mangle(ep.node[1:])}/{mangle(ep.name)}/{dds_name(ep.type_name)}/"
            f"{ep.type_hash}/{qos}"
        )

    def refresh(self) -> None:
        """Announce what the bus has now, withdraw what it no longer has."""
        wanted = self._endpoints()
        liveliness = self.session.liveliness()
        with self._lock:
            for ep in [e for e in self._tokens if e not in wanted]:
                self._tokens.pop(ep).undeclare()
                if ep.kind == "MP":
                    self._drop_outgoing(ep.name)
                elif ep.kind == "SS":
                    self._queryables.pop(ep.name).undeclare()
            for ep in wanted - self._tokens.keys():
                if ep.node not in self._node_tokens:
                    self._node_tokens[ep.node] = liveliness.declare_token(self._node_key(ep.node))
                key = self._token_key(ep, next(self._entity_ids))
                if ep.kind == "MP":
                    self._add_outgoing(ep, key)
                elif ep.kind == "SS":
                    self._add_service(ep)
                self._tokens[ep] = liveliness.declare_token(key)
            used = {ep.node for ep in self._tokens}
            for node in [n for n in self._node_tokens if n not in used]:
                self._node_tokens.pop(node).undeclare()

    # --- bus topics out -----------------------------------------------------------------

    def _add_outgoing(self, ep: Endpoint, token_key: str) -> None:
        if ep.name in self._outgoing:
            return
        from zenoh import ext

        cls = lookup_message(ep.type_name)
        assert cls is not None
        key = self.data_key(ep.name, ep.type_name, ep.type_hash)
        if ep.latched:
            pub = ext.declare_advanced_publisher(
                self.session,
                key,
                cache=ext.CacheConfig(max_samples=1),
                sample_miss_detection=ext.MissDetectionConfig(
                    heartbeat=None, sporadic_heartbeat=0.5
                ),
                publisher_detection=True,
            )
        else:
            pub = self.session.declare_publisher(key)
        gid = hashlib.blake2b(token_key.encode(), digest_size=16).digest()
        out = _Outgoing(ep.name, cls, pub, gid, ep.latched)
        self._outgoing[ep.name] = out
        self._update_forwarding(ep.name)

    def _drop_outgoing(self, topic: str) -> None:
        out = self._outgoing.pop(topic, None)
        if out is None:
            return
        if out.bus_sub is not None:
            out.bus_sub.close()
        out.publisher.undeclare()

    def _update_forwarding(self, topic: str) -> None:
        """Subscribe to the bus topic while someone on Zenoh listens (always when latched)."""
        out = self._outgoing.get(topic)
        if out is None:
            return
        wanted = out.latched or bool(self._remote_subs.get(topic))
        if wanted and out.bus_sub is None:
            out.bus_sub = self.create_subscription(
                topic, out.cls, lambda msg, o=out: self._send(o, msg)
            )
        elif not wanted and out.bus_sub is not None:
            out.bus_sub.close()
            out.bus_sub = None

    def _send(self, out: _Outgoing, msg: Any) -> None:
        if not isinstance(msg, out.cls):
            return
        att = attachment(next(out.sequence), time.time_ns(), out.gid)
        try:
            out.publisher.put(cdr.serialize(msg), attachment=att)
        except Exception as exc:  # a closed session while shutting down
            log.debug("zenoh: %s not sent: %s", out.topic, exc)

    # --- the ROS 2 graph in ----------------------------------------------------------------

    def _on_token(self, sample: Any) -> None:
        key = str(sample.key_expr)
        parts = key.split("/")
        if len(parts) < 13 or parts[2] == self.zid or parts[5] not in ("MP", "MS"):
            return
        topic = "/" + parts[9].replace("%", "/").lstrip("/")
        alive = sample.kind == self._zenoh.SampleKind.PUT
        with self._lock:
            if parts[5] == "MS":
                subs = self._remote_subs.setdefault(topic, set())
                (subs.add if alive else subs.discard)(key)
                self._update_forwarding(topic)
            else:
                self._remote_publisher(topic, parts[10], parts[11], alive)

    def _remote_publisher(self, topic: str, dds: str, type_hash: str, alive: bool) -> None:
        """Take a remote publisher's messages onto the bus (a type robotrial knows)."""
        parts = dds.split("::")
        if len(parts) != 4:
            return
        pkg, kind, _, name = parts
        cls = lookup_message(f"{pkg}/{kind}/{name.rstrip('_')}")
        if cls is None or message_hash(cls) != type_hash:
            return
        key = self.data_key(topic, cls.__ros_type__, type_hash)
        if not alive or key in self._incoming:
            return
        known = self.bus.topic_type(topic)
        if known and known != cls.__ros_type__:
            log.warning("zenoh: %s is %s on the bus, not %s", topic, known, cls.__ros_type__)
            return
        pub = self.create_publisher(topic, cls)

        def on_sample(sample: Any) -> None:
            try:
                msg = deserialize(sample.payload.to_bytes(), cls.__ros_type__, "ros2")
            except Exception as exc:  # bytes that are not the type named in the key
                log.warning("zenoh: a message on %s does not decode: %s", topic, exc)
                return
            pub.publish(msg)

        sub = self.session.declare_subscriber(
            key, on_sample, allowed_origin=self._zenoh.Locality.REMOTE
        )
        self._incoming[key] = (sub, pub)

    # --- services -----------------------------------------------------------------------

    def _add_service(self, ep: Endpoint) -> None:
        srv = lookup_service(ep.type_name)
        assert srv is not None
        key = self.data_key(ep.name, ep.type_name, ep.type_hash)

        def on_query(query: Any) -> None:
            self._calls.submit(self._answer, query, ep.name, srv, key)

        self._queryables[ep.name] = self.session.declare_queryable(key, on_query, complete=True)

    def _answer(self, query: Any, service: str, srv: ServiceType, key: str) -> None:
        try:
            seq, _, gid = parse_attachment(query.attachment.to_bytes())
            payload = query.payload.to_bytes() if query.payload is not None else b""
            request = deserialize(payload, srv.Request.__ros_type__, "ros2")
            response = self.bus.call(service, request, SERVICE_TIMEOUT)
            query.reply(
                key, cdr.serialize(response), attachment=attachment(seq, time.time_ns(), gid)
            )
        except Exception as exc:  # the handler failed, or the request was not a request
            log.warning("zenoh: call of %s failed: %s", service, exc)
            query.reply_err(str(exc))
        finally:
            query.drop()

    def destroy(self) -> None:
        """Withdraw everything from the ROS 2 graph and close the Zenoh session."""
        super().destroy()
        with self._lock:
            for topic in list(self._outgoing):
                self._drop_outgoing(topic)
            for sub, _ in self._incoming.values():
                sub.undeclare()
            self._incoming.clear()
        self._calls.shutdown(wait=False, cancel_futures=True)
        try:
            self._graph.undeclare()
            self.session.close()
        except Exception as exc:
            log.debug("zenoh: closing: %s", exc)
