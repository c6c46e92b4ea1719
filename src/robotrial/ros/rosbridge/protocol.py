"""The rosbridge v2 protocol: one `Session` per client over a shared `Bus` (layer 4).

Transport-free: a session is fed frames with `receive()` and hands frames to the `send`
coroutine it was given, so the WebSocket route, the standalone server and the tests all
drive the same code. Every failure of a client's operation becomes a `status` message
(with the operation's `id`) or, for `call_service`, a failed `service_response`; nothing
a client sends ends the session, and `close()` removes everything the client created.

Outgoing traffic goes through one writer task per session. Each subscription keeps a
bounded queue (`queue_length`; 0 means the server's default bound, or only the newest
message when the subscription is throttled), so a slow client loses its oldest messages
instead of growing memory, and a message published to many
clients is encoded once per encoding. Large messages (point clouds, images, maps) are
encoded in a worker thread, so the event loop that serves every client never waits on
them; a client that has not taken a frame for `Limits.stall_timeout` seconds (it stopped
reading) is disconnected with the reason, and its queues freed.
"""

from __future__ import annotations

import asyncio
import collections
import concurrent.futures
import inspect
import itertools
import logging
import math
import threading
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any

from robotrial.msgs import DIALECTS, Dialect, Message, MessageError, lookup_action, type_dialect
from robotrial.msgs.core import use_clock
from robotrial.ros import actions, tf_republisher
from robotrial.ros.bus import Bus, BusError, Node, Publisher, ServiceServer, Subscription
from robotrial.ros.rosbridge import encoding
from robotrial.ros.rosbridge.access import Access
from robotrial.ros.rosbridge.encoding import ProtocolError, Reassembly
from robotrial.ros.rosbridge.rosapi import Rosapi
from robotrial.ros.tf_republisher import TfRepublisher

log = logging.getLogger(__name__)

LEVELS = {"info": 0, "warning": 1, "error": 2, "none": 3}
COMPRESSIONS = ("none", "cbor", "cbor-raw", "png")
MAX_QUEUE_LENGTH = 10_000
HEAVY_BYTES = 64 * 1024
"""A message whose `data` is larger than this is encoded off the event loop."""
CACHE_BYTES = 32 * 2**20
"""At most this many bytes of encoded frames are kept for other clients to reuse."""
Send = Callable[[str | bytes], Awaitable[None]]


class ClientStalled(Exception):
    """The client stopped reading: a frame waited longer than `Limits.stall_timeout`."""


@dataclass(frozen=True)
class Limits:
    """Bounds that keep one client from exhausting the server."""

    max_message_bytes: int = 16 * 2**20  # one incoming frame or reassembled message
    max_subscriptions: int = 512  # topics per client
    max_calls_in_flight: int = 256  # call_service per client awaiting an answer
    default_queue_length: int = 100  # a subscription's bound when queue_length is 0
    max_control_frames: int = 10_000  # queued responses and statuses per client
    service_timeout: float = 120.0  # s, when call_service names no timeout
    stall_timeout: float = 5.0  # s a frame may wait for the client to read before it is dropped


def _opt(op: dict, key: str, kind: type | tuple, default: Any = None) -> Any:
    value = op.get(key, default)
    if value is None:
        return default
    if kind is int and type(value) is float and value.is_integer():
        value = int(value)
    if isinstance(value, bool) and kind is not bool:
        raise ProtocolError(f"'{key}' must be {_kind_name(kind)}, got a boolean")
    if not isinstance(value, kind):
        raise ProtocolError(f"'{key}' must be {_kind_name(kind)}, got {type(value).__name__}")
    return value


def _req(op: dict, key: str, kind: type | tuple) -> Any:
    if op.get(key) is None:
        raise ProtocolError(f"missing field '{key}'")
    return _opt(op, key, kind)


def _kind_name(kind: type | tuple) -> str:
    names = {str: "a string", int: "an integer", float: "a number", bool: "a boolean"}
    names[dict] = "an object"
    if isinstance(kind, tuple):
        return " or ".join(names.get(k, k.__name__) for k in kind)
    return names.get(kind, kind.__name__)


def _nonneg(op: dict, key: str, default: float, maximum: float = 1e9) -> float:
    value = _opt(op, key, (int, float), default)
    if not math.isfinite(value) or not 0 <= value <= maximum:
        raise ProtocolError(f"'{key}' must be between 0 and {maximum:g}, got {value}")
    return value


def _name(op: dict, key: str) -> str:
    """A required topic or service name; relative names (roslibjs's `rosapi/get_param`)
    are taken from the root."""
    name = _req(op, key, str)
    return name if name.startswith("/") else "/" + name


def _id_key(oid: Any) -> Any:
    """A subscribe id usable as a dict key (clients may send any JSON value)."""
    if oid is None or isinstance(oid, str | int | float):
        return oid
    return repr(oid)


def _plain_id(oid: Any) -> Any:
    return oid if isinstance(oid, str | int | float) and not isinstance(oid, bool) else str(oid)


@dataclass(eq=False)
class ClientSubscription:
    """One client's subscription to one topic (several subscribe ids may share it)."""

    topic: str
    wire_name: str  # the topic as the client spelled it, echoed in publish operations
    dialect: Dialect
    compression: str
    fragment_size: int
    throttle_s: float
    queue: collections.deque
    sids: dict[Any, tuple[float, int]] = field(default_factory=dict)
    bus_sub: Subscription | None = None
    last_sent: float = -1e9


class RosbridgeServer:
    """The rosbridge side of a bus: its sessions, the rosapi node and an encoding cache."""

    def __init__(
        self,
        bus: Bus,
        *,
        dialect: Dialect = "ros2",
        limits: Limits | None = None,
        rosapi: bool = True,
        access: Access | None = None,
    ) -> None:
        if dialect not in DIALECTS:
            raise ValueError(f"dialect must be one of {DIALECTS}, got {dialect!r}")
        self.bus = bus
        self.dialect = dialect
        self.limits = limits or Limits()
        self.access = access or Access()
        self.sessions: set[Session] = set()
        self.rosapi = (
            Rosapi(bus, dialect) if rosapi and bus.service("/rosapi/topics") is None else None
        )
        # what roslibjs's TFClient and ROS2TFClient ask for, as a rosbridge host runs it
        self.tf_republisher = (
            TfRepublisher(bus) if rosapi and tf_republisher.SERVER not in bus.actions else None
        )
        self._cache: collections.OrderedDict[tuple, tuple[Any, str | bytes]] = (
            collections.OrderedDict()
        )
        self._cache_bytes = 0
        self._cache_lock = threading.Lock()
        self.encoder = concurrent.futures.ThreadPoolExecutor(1, "rosbridge-encode")
        self._counter = itertools.count(1)
        self._wake_lock = threading.Lock()
        self._to_wake: set[Session] = set()
        self._wake_scheduled = False

    def open_session(self, send: Send, name: str = "/rosbridge_websocket/client") -> Session:
        """A new client session; call from the event loop that will run it."""
        session = Session(self, send, self.bus.unique_node_name(name))
        self.sessions.add(session)
        return session

    def close(self) -> None:
        """Withdraw the rosapi and TF republisher nodes (sessions close with their
        connections)."""
        if self.rosapi is not None:
            self.rosapi.destroy()
            self.rosapi = None
        if self.tf_republisher is not None:
            self.tf_republisher.destroy()
            self.tf_republisher = None
        self.encoder.shutdown(wait=False, cancel_futures=True)

    def encode_publish(
        self, topic: str, msg: Any, dialect: Dialect, compression: str
    ) -> str | bytes:
        """The publish frame of `msg` on `topic`, encoded once for all clients that want
        the same dialect and compression (any thread)."""
        key = (id(msg), topic, dialect, compression)
        with self._cache_lock:
            hit = self._cache.get(key)
        if hit is not None and hit[0] is msg:
            return hit[1]
        frame = self._encode(topic, msg, dialect, compression)
        with self._cache_lock:
            old = self._cache.pop(key, None)
            if old is not None:
                self._cache_bytes -= len(old[1])
            self._cache[key] = (msg, frame)
            self._cache_bytes += len(frame)
            while len(self._cache) > 256 or self._cache_bytes > CACHE_BYTES:
                _, (_, dropped) = self._cache.popitem(last=False)
                self._cache_bytes -= len(dropped)
        return frame

    async def encode_publish_async(
        self, topic: str, msg: Any, dialect: Dialect, compression: str
    ) -> str | bytes:
        """encode_publish, in the encoder thread when `msg` is large."""
        data = getattr(msg, "data", None)
        if isinstance(data, bytes | bytearray | list | tuple) and len(data) > HEAVY_BYTES:
            loop = asyncio.get_running_loop()
            return await loop.run_in_executor(
                self.encoder, self.encode_publish, topic, msg, dialect, compression
            )
        return self.encode_publish(topic, msg, dialect, compression)

    def _encode(self, topic: str, msg: Any, dialect: Dialect, compression: str) -> str | bytes:
        if compression == "cbor-raw":
            from robotrial.msgs import cdr

            ns = self.bus.now_ns()
            raw = {"secs": ns // 1_000_000_000, "nsecs": ns % 1_000_000_000}
            raw["bytes"] = cdr.serialize_ros1(msg) if dialect == "ros1" else cdr.serialize(msg)
            return encoding.encode_op({"op": "publish", "topic": topic, "msg": raw}, "cbor")
        if isinstance(msg, Message):
            body = msg.to_wire(dialect) if compression == "cbor" else msg.to_dict(dialect)
        else:
            body = msg
        return encoding.encode_op({"op": "publish", "topic": topic, "msg": body}, compression)

    def next_id(self) -> int:
        return next(self._counter)

    def wake_from_thread(self, session: Session) -> None:
        """Wake a session's writer from a publisher thread. One publish reaching many
        sessions costs one loop wake-up, not one per session."""
        with self._wake_lock:
            self._to_wake.add(session)
            if self._wake_scheduled:
                return
            self._wake_scheduled = True
        try:
            session.loop.call_soon_threadsafe(self._wake_sessions)
        except RuntimeError:
            pass  # the loop has closed: the sessions are going away

    def _wake_sessions(self) -> None:
        with self._wake_lock:
            sessions, self._to_wake = self._to_wake, set()
            self._wake_scheduled = False
        for s in sessions:
            s._wake.set()


class Session:
    """One connected client: its subscriptions, publishers, offered services and calls."""

    def __init__(self, server: RosbridgeServer, send: Send, name: str) -> None:
        self.server = server
        self.bus: Bus = server.bus
        self.limits = server.limits
        self.loop = asyncio.get_running_loop()
        self._thread = threading.get_ident()
        self._send = send
        self.node = Node(self.bus, name)
        self.subscriptions: dict[str, ClientSubscription] = {}
        self.publishers: dict[str, Publisher] = {}
        self.services: dict[str, ServiceServer] = {}
        self.pending: dict[str, tuple[str, asyncio.Future]] = {}  # calls this client answers
        self.calls: set[asyncio.Task] = set()  # this client's call_service in flight
        self.goals: dict[Any, actions.GoalHandle] = {}  # this client's action goals by id
        self.level = LEVELS["error"]
        self.fragments = Reassembly(self.limits.max_message_bytes)
        self.closed = False
        self.authenticated = server.access.token is None
        self.ended = asyncio.Event()  # set once closed, so the transport can drop the socket
        self.close_reason = ""  # why the server ended the session, for the close frame
        self.refused = False  # a wrong token was sent: nothing more is read
        self._control: collections.deque[str | bytes] = collections.deque()
        self._wake = asyncio.Event()
        self._timer: asyncio.Handle | None = None
        # When the timer fires (loop time): uvloop's handles have no when().
        self._timer_due = 0.0
        self._ops: dict[str, Callable[[dict], Any]] = {
            "advertise": self._advertise,
            "unadvertise": self._unadvertise,
            "publish": self._publish,
            "subscribe": self._subscribe,
            "unsubscribe": self._unsubscribe,
            "call_service": self._call_service,
            "advertise_service": self._advertise_service,
            "unadvertise_service": self._unadvertise_service,
            "service_response": self._service_response,
            "send_action_goal": self._send_action_goal,
            "cancel_action_goal": self._cancel_action_goal,
            "fragment": self._fragment,
            "png": self._png,
            "set_level": self._set_level,
            "auth": self._auth,
        }
        self._writer = self.loop.create_task(self._write_loop())

    @property
    def name(self) -> str:
        return self.node.name

    # ------------------------------------------------------------ incoming

    async def receive(self, data: str | bytes, depth: int = 0) -> None:
        """Handle one frame from the client; errors go back as status messages."""
        if self.closed or self.refused:
            return
        if len(data) > self.limits.max_message_bytes:
            self.status(
                "error",
                f"message of {len(data)} bytes is larger than the limit of "
                f"{self.limits.max_message_bytes} bytes; it was dropped",
            )
            return
        try:
            op = encoding.loads(data)
        except ProtocolError as exc:
            self.status("error", str(exc))
            return
        await self.handle(op, depth)

    async def handle(self, op: Any, depth: int = 0) -> None:
        """Carry out one decoded operation."""
        if not isinstance(op, dict):
            self.status("error", f"expected a JSON object with an 'op', got {type(op).__name__}")
            return
        try:
            encoding.check_depth(op, "the operation")
        except ProtocolError as exc:
            oid = op.get("id")
            self.status("error", str(exc), oid if isinstance(oid, str | int) else None)
            return
        oid = op.get("id")
        name = op.get("op")
        if not isinstance(name, str):
            self.status("error", "missing field 'op' (a string)", oid)
            return
        handler = self._ops.get(name)
        if handler is None:
            self.status("error", f"unknown op {name!r}", oid)
            return
        if not self.authenticated and name != "auth":
            self.status(
                "error",
                f"{name}: not authenticated; this server needs a token: send "
                '{"op": "auth", "mac": TOKEN} first',
                oid,
            )
            return
        try:
            if name in ("fragment", "png"):
                if depth > 1:
                    raise ProtocolError(f"{name} nested inside another {name}")
                await handler(op, depth + 1)
            else:
                with use_clock(self.bus.now_ns):  # "now" in a message is the bus's time
                    result = handler(op)
                if inspect.isawaitable(result):
                    await result
                elif name == "publish":
                    # let the subscribers' writers take this message before the next
                    # frame is read, so a burst of publishes does not overrun queue_length 1
                    await asyncio.sleep(0)
        except (ProtocolError, MessageError, BusError) as exc:
            self.status("error", f"{name}: {exc}", oid)
        except Exception as exc:
            log.exception("rosbridge op %s failed", name)
            self.status("error", f"{name}: internal error: {exc}", oid)

    def _auth(self, op: dict) -> None:
        """rosbridge's auth op; the token goes in `mac`. A wrong token ends the session at
        once: nothing the client sends after it is read."""
        if self.authenticated:
            return
        if self.server.access.token_ok(op.get("mac") if isinstance(op.get("mac"), str) else None):
            self.authenticated = True
            return
        self.refused = True
        self.close_reason = "wrong token"
        self.status("error", "auth: wrong token; the connection is closed")
        self.loop.call_later(0.2, lambda: self.loop.create_task(self.close()))

    def _advertise(self, op: dict) -> None:
        topic = _name(op, "topic")
        type_name = _req(op, "type", str)
        latched = _opt(op, "latch", bool, False)
        pub = self.publishers.get(topic)
        if pub is not None:
            if _same_type(type_name, pub.type_name) is False:
                raise ProtocolError(f"{topic} is already advertised with type {pub.type_name}")
            return
        self.publishers[topic] = self.bus.advertise(
            topic, type_name, latched=latched or None, node=self.name
        )

    def _unadvertise(self, op: dict) -> None:
        topic = _name(op, "topic")
        pub = self.publishers.pop(topic, None)
        if pub is None:
            self.status("warning", f"unadvertise: {topic} was not advertised", op.get("id"))
            return
        pub.close()

    def _publish(self, op: dict) -> None:
        topic = _name(op, "topic")
        msg = _opt(op, "msg", dict, {})
        pub = self.publishers.get(topic)
        if pub is None:
            known = self.bus.topic_type(topic)
            if not known:
                raise ProtocolError(f"{topic} has no type yet: advertise it first")
            pub = self.publishers[topic] = self.bus.advertise(topic, known, node=self.name)
        pub.publish(msg)

    def _subscribe(self, op: dict) -> None:
        topic = _name(op, "topic")
        wire_name = op["topic"]
        type_name = _opt(op, "type", str, "")
        throttle_ms = _nonneg(op, "throttle_rate", 0)
        queue_length = int(_nonneg(op, "queue_length", 0, MAX_QUEUE_LENGTH))
        fragment_size = int(_nonneg(op, "fragment_size", 0))
        compression = _opt(op, "compression", str, "none")
        if compression not in COMPRESSIONS:
            raise ProtocolError(f"compression must be one of {', '.join(COMPRESSIONS)}")
        sid = _id_key(op.get("id"))
        dialect = type_dialect(type_name) or self.server.dialect
        # queue_length 0 with a throttle keeps only the newest message: what arrives
        # between two sends is dropped, as rosbridge_suite does
        bound = queue_length or (1 if throttle_ms > 0 else self.limits.default_queue_length)
        sub = self.subscriptions.get(topic)
        if sub is None:
            if not type_name and not self.bus.topic_type(topic):
                raise ProtocolError(
                    f"cannot infer the type of {topic}: it is not advertised yet; name it in 'type'"
                )
            if len(self.subscriptions) >= self.limits.max_subscriptions:
                raise ProtocolError(
                    f"this client already has {self.limits.max_subscriptions} subscriptions"
                )
            sub = ClientSubscription(
                topic,
                wire_name,
                dialect,
                compression,
                fragment_size,
                throttle_ms / 1000.0,
                collections.deque(maxlen=bound),
            )
            sub.sids[sid] = (throttle_ms, bound)
            self.subscriptions[topic] = sub
            try:
                sub.bus_sub = self.bus.subscribe(
                    topic,
                    lambda msg, s=sub: self._on_message(s, msg),
                    type_name or None,
                    node=self.name,
                )
            except BusError:
                del self.subscriptions[topic]
                raise
            return
        if type_name and self.bus.topic_type(topic):
            if _same_type(type_name, self.bus.topic_type(topic)) is False:
                raise ProtocolError(f"{topic} has type {self.bus.topic_type(topic)}")
        sub.sids[sid] = (throttle_ms, bound)
        sub.dialect, sub.compression, sub.fragment_size = dialect, compression, fragment_size
        sub.throttle_s = min(t for t, _ in sub.sids.values()) / 1000.0
        new_bound = max(b for _, b in sub.sids.values())
        if new_bound != sub.queue.maxlen:
            sub.queue = collections.deque(sub.queue, maxlen=new_bound)

    def _unsubscribe(self, op: dict) -> None:
        topic = _name(op, "topic")
        sub = self.subscriptions.get(topic)
        sid = _id_key(op.get("id"))
        if sub is None:
            self.status("warning", f"unsubscribe: not subscribed to {topic}", sid)
            return
        if sid is not None and sid in sub.sids and len(sub.sids) > 1:
            del sub.sids[sid]
            sub.throttle_s = min(t for t, _ in sub.sids.values()) / 1000.0
            return
        self._drop_subscription(sub)

    def _drop_subscription(self, sub: ClientSubscription) -> None:
        self.subscriptions.pop(sub.topic, None)
        if sub.bus_sub is not None:
            sub.bus_sub.close()
        sub.queue.clear()

    def _call_service(self, op: dict) -> None:
        service = _name(op, "service")
        args = op.get("args")
        if args is not None and not isinstance(args, dict | list):
            raise ProtocolError("'args' must be an object or an array")
        timeout = _opt(op, "timeout", (int, float), None)
        if timeout is not None and not 0 < timeout < math.inf:
            raise ProtocolError(f"'timeout' must be > 0 s, got {timeout}")
        compression = _opt(op, "compression", str, "none")
        if compression not in COMPRESSIONS:
            raise ProtocolError(f"compression must be one of {', '.join(COMPRESSIONS)}")
        fragment_size = int(_nonneg(op, "fragment_size", 0))
        dialect = type_dialect(_opt(op, "type", str, "")) or self.server.dialect
        if len(self.calls) >= self.limits.max_calls_in_flight:
            raise ProtocolError(f"more than {self.limits.max_calls_in_flight} calls in flight")
        task = self.loop.create_task(
            self._call(
                service,
                op["service"],
                args,
                op.get("id"),
                timeout,
                dialect,
                compression,
                fragment_size,
            )
        )
        self.calls.add(task)
        task.add_done_callback(self.calls.discard)

    async def _call(
        self,
        service: str,
        wire_name: str,
        args: Any,
        oid: Any,
        timeout: float | None,
        dialect: Dialect,
        compression: str,
        fragment_size: int,
    ) -> None:
        out: dict[str, Any] = {"op": "service_response", "service": wire_name}
        if oid is not None:
            out["id"] = _plain_id(oid)
        try:
            if isinstance(args, list):
                args = self._positional(service, args)
            resp = await self.bus.call_async(
                service, args or {}, timeout or self.limits.service_timeout
            )
            out["values"] = resp.to_dict(dialect) if isinstance(resp, Message) else resp
            if service == "/rosapi/get_time" and dialect == "ros2":
                # roslibpy's get_time() reads secs/nsecs whatever the ROS version
                t = out["values"]["time"]
                t.update(secs=t["sec"], nsecs=t["nanosec"])
            out["result"] = True
        except asyncio.CancelledError:
            raise
        except (BusError, MessageError, ProtocolError, TimeoutError) as exc:
            out["values"] = str(exc)
            out["result"] = False
        except Exception as exc:
            log.exception("call_service %s failed", service)
            out["values"] = f"internal error: {exc}"
            out["result"] = False
        if compression == "cbor-raw":
            compression = "cbor"
        self.send_op(out, compression, fragment_size)

    def _positional(self, service: str, args: list) -> dict:
        server = self.bus.service(service)
        if server is None or server.srv is None:
            raise ProtocolError(f"{service}: positional args need a service of a known type")
        names = [s.name for s in server.srv.Request.__fields_spec__]
        if len(args) > len(names):
            raise ProtocolError(f"{service}: {len(args)} args for {len(names)} request fields")
        return dict(zip(names, args, strict=False))

    def _advertise_service(self, op: dict) -> None:
        service = _name(op, "service")
        type_name = _req(op, "type", str)
        if service in self.services:
            raise ProtocolError(f"{service} is already advertised by this client")
        dialect = type_dialect(type_name) or self.server.dialect
        self.services[service] = self.bus.advertise_service(
            service,
            type_name,
            self._remote_handler(service, op["service"], dialect),
            node=self.name,
        )

    def _remote_handler(
        self, service: str, wire_name: str, dialect: Dialect
    ) -> Callable[[Any], Awaitable[Any]]:
        async def call_client(request: Any) -> Any:
            if self.closed:
                raise BusError(f"the client offering {service} has disconnected")
            cid = f"service_request:{service}:{self.server.next_id()}"
            fut: asyncio.Future = self.loop.create_future()
            self.pending[cid] = (service, fut)
            args = request.to_dict(dialect) if isinstance(request, Message) else request
            self.send_op({"op": "call_service", "id": cid, "service": wire_name, "args": args})
            try:
                return await fut
            finally:
                self.pending.pop(cid, None)

        return call_client

    def _unadvertise_service(self, op: dict) -> None:
        service = _name(op, "service")
        server = self.services.pop(service, None)
        if server is None:
            self.status("warning", f"unadvertise_service: {service} is not ours", op.get("id"))
            return
        server.close()
        self._fail_pending(server.name, f"{service} was withdrawn by its provider")

    def _service_response(self, op: dict) -> None:
        cid = _req(op, "id", (str, int))
        entry = self.pending.get(str(cid))
        if entry is None:
            self.status("warning", f"service_response: no call with id {cid!r} is waiting", cid)
            return
        _, fut = entry
        result = _opt(op, "result", bool, True)
        values = op.get("values")
        if fut.done():
            return
        if not result:
            fut.set_exception(BusError(f"provider answered with failure: {values}"))
        elif values is not None and not isinstance(values, dict):
            fut.set_exception(BusError("provider answered with values that are not an object"))
        else:
            fut.set_result(values or {})

    def _send_action_goal(self, op: dict) -> None:
        """Start a goal on a bus action; feedback and the result come back tagged with
        the operation's `id`."""
        action = _name(op, "action")
        wire_name = op["action"]
        type_name = _opt(op, "action_type", str, "")
        args = _opt(op, "args", dict, {})
        want_feedback = _opt(op, "feedback", bool, False)
        compression = _opt(op, "compression", str, "none")
        if compression not in COMPRESSIONS:
            raise ProtocolError(f"compression must be one of {', '.join(COMPRESSIONS)}")
        compression = "cbor" if compression == "cbor-raw" else compression
        fragment_size = int(_nonneg(op, "fragment_size", 0))
        oid = op.get("id")
        if oid is None:
            oid = f"send_action_goal:{action}:{self.server.next_id()}"
        key = _id_key(oid)
        if key in self.goals and self.goals[key].active:
            raise ProtocolError(f"a goal with id {oid!r} is still running")
        dialect = type_dialect(type_name) or self.server.dialect
        head = {"action": wire_name, "id": _plain_id(oid)}

        def on_feedback(msg: Message) -> None:
            out = {"op": "action_feedback", **head, "values": msg.to_dict(dialect)}
            self._send_any_thread(out, compression, fragment_size)

        def on_result(handle: actions.GoalHandle) -> None:
            values = handle.result.to_dict(dialect) if handle.result is not None else {}
            out = {"op": "action_result", **head, "values": values}
            out.update(status=handle.status, result=True)
            if self.goals.get(key) is handle:
                del self.goals[key]
            self._send_any_thread(out, compression, fragment_size)

        try:
            server = actions.action_server(self.bus, action)
            if type_name and lookup_action(type_name) is not server.type:
                raise ProtocolError(f"{action} has type {server.type_name}, not {type_name}")
            handle = server.send_goal(args, on_feedback if want_feedback else None, on_result)
        except (BusError, MessageError, ProtocolError) as exc:
            out = {"op": "action_result", **head, "values": str(exc)}
            out.update(status=actions.ABORTED, result=False)
            self.send_op(out)
            raise
        if handle.active:
            self.goals[key] = handle

    def _cancel_action_goal(self, op: dict) -> None:
        """Ask the action server to cancel this client's goal `id`."""
        action = _name(op, "action")
        oid = _req(op, "id", (str, int))
        handle = self.goals.get(_id_key(oid))
        if handle is None or handle.server.name != action or not handle.active:
            self.status("warning", f"cancel_action_goal: no running goal {oid!r} on {action}", oid)
            return
        handle.server.cancel_goal(handle.id)

    def _send_any_thread(self, op: dict, compression: str, fragment_size: int) -> None:
        """send_op from the bus's threads (an action server may report from any)."""
        if self.closed:
            return
        if threading.get_ident() == self._thread:
            self.send_op(op, compression, fragment_size)
        else:
            try:
                self.loop.call_soon_threadsafe(self.send_op, op, compression, fragment_size)
            except RuntimeError:
                pass  # the loop has closed: the session is going away

    def _fail_pending(self, service: str | None, reason: str) -> None:
        for _, (name, fut) in list(self.pending.items()):
            if (service is None or name == service) and not fut.done():
                fut.set_exception(BusError(reason))

    async def _fragment(self, op: dict, depth: int) -> None:
        whole = self.fragments.add(op)
        if whole is not None:
            await self.receive(whole, depth)

    async def _png(self, op: dict, depth: int) -> None:
        data = _req(op, "data", str)
        if len(data) > self.limits.max_message_bytes:
            raise ProtocolError("png data larger than the message limit")
        await self.receive(encoding.png_unpack(data), depth)

    def _set_level(self, op: dict) -> None:
        level = _req(op, "level", str)
        if level not in LEVELS:
            raise ProtocolError(f"level must be one of {', '.join(LEVELS)}")
        self.level = LEVELS[level]

    # ------------------------------------------------------------ outgoing

    def status(self, level: str, msg: str, oid: Any = None) -> None:
        """Send a status message if the client's level lets it through."""
        if LEVELS[level] < self.level:
            return
        op: dict[str, Any] = {"op": "status", "level": level, "msg": msg}
        if oid is not None:
            op["id"] = _plain_id(oid)
        self.send_op(op)

    def send_op(self, op: dict, compression: str = "none", fragment_size: int = 0) -> None:
        """Queue an operation for the client (encoded now, written by the writer task)."""
        if self.closed:
            return
        frame = encoding.encode_op(op, "cbor" if compression == "cbor-raw" else compression)
        if isinstance(frame, str) and fragment_size:
            frames = encoding.fragments(
                frame, fragment_size, str(op.get("id", self.server.next_id()))
            )
        else:
            frames = [frame]
        self._control.extend(frames)
        while len(self._control) > self.limits.max_control_frames:
            self._control.popleft()
        self._wake.set()

    def _on_message(self, sub: ClientSubscription, msg: Any) -> None:
        # runs in the publisher's thread
        if self.closed or self.subscriptions.get(sub.topic) is not sub:
            return
        sub.queue.append(msg)
        if threading.get_ident() == self._thread:
            self._wake.set()
        else:
            self.server.wake_from_thread(self)

    async def _write_loop(self) -> None:
        try:
            while True:
                await self._wake.wait()
                self._wake.clear()
                await self._flush()
        except asyncio.CancelledError:
            raise
        except ClientStalled as exc:
            log.warning("rosbridge client %s: %s", self.name, exc)
            self.close_reason = str(exc)
            self.loop.create_task(self.close())
        except Exception as exc:
            log.debug("rosbridge client %s: send failed (%s); closing", self.name, exc)
            self.loop.create_task(self.close())

    async def _deliver(self, frame: str | bytes) -> None:
        """Hand one frame to the transport; a client that does not take it within
        `stall_timeout` seconds has stopped reading and is dropped."""
        try:
            async with asyncio.timeout(self.limits.stall_timeout):
                await self._send(frame)
        except TimeoutError:
            raise ClientStalled(
                f"the client did not read its messages for {self.limits.stall_timeout:g} s "
                "(its backlog stayed full); disconnected"
            ) from None

    async def _flush(self) -> None:
        while not self.closed:
            sent = False
            while self._control:
                await self._deliver(self._control.popleft())
                sent = True
            now = self.loop.time()
            for sub in list(self.subscriptions.values()):
                if not sub.queue:
                    continue
                if sub.throttle_s > 0:
                    wait = sub.last_sent + sub.throttle_s - now
                    if wait > 0:
                        self._wake_later(wait)
                        continue
                msg = sub.queue.popleft()
                sub.last_sent = now
                try:
                    frame = await self.server.encode_publish_async(
                        sub.wire_name, msg, sub.dialect, sub.compression
                    )
                except Exception as exc:
                    log.warning("message on %s not encodable: %s", sub.topic, exc)
                    self.status(
                        "error", f"a message on {sub.wire_name} could not be encoded: {exc}"
                    )
                    continue
                if isinstance(frame, str) and sub.fragment_size:
                    fid = f"publish:{sub.topic}:{self.server.next_id()}"
                    for piece in encoding.fragments(frame, sub.fragment_size, fid):
                        await self._deliver(piece)
                else:
                    await self._deliver(frame)
                sent = True
            if not sent:
                return

    def _wake_later(self, delay: float) -> None:
        due = self.loop.time() + delay
        if self._timer is None or self._timer_due > due:
            if self._timer is not None:
                self._timer.cancel()
            self._timer = self.loop.call_later(delay, self._timer_fired)
            self._timer_due = due

    def _timer_fired(self) -> None:
        self._timer = None
        self._wake.set()

    async def close(self) -> None:
        """Remove everything this client created; answer calls waiting on it with errors."""
        if self.closed:
            return
        self.closed = True
        for sub in list(self.subscriptions.values()):
            self._drop_subscription(sub)
        for pub in self.publishers.values():
            pub.close()
        self.publishers.clear()
        for srv in self.services.values():
            srv.close()
        self.services.clear()
        self._fail_pending(None, f"the client {self.name} disconnected")
        for handle in list(self.goals.values()):
            if handle.active:
                handle.server.cancel_goal(handle.id)
        self.goals.clear()
        for task in list(self.calls):
            task.cancel()
        if self._timer is not None:
            self._timer.cancel()
        self._control.clear()
        self._writer.cancel()
        self.node.destroy()
        self.server.sessions.discard(self)
        self.ended.set()


def _same_type(a: str, b: str) -> bool | None:
    """Whether two type names (any spelling) name the same type; None when unknown."""
    from robotrial.ros.bus import canonical_type

    try:
        return canonical_type(a)[0] == canonical_type(b)[0]
    except BusError:
        return None
