"""The bus over the Foxglove WebSocket protocol, for Foxglove and Lichtblick (layer 4).

`FoxgloveBridge` is a server of the protocol's `foxglove.websocket.v1` subprotocol
(github.com/foxglove/ws-protocol, docs/spec.md), on the `websockets` package, in a thread
of its own next to the bus:

- every bus topic of a type in `robotrial.msgs` is a channel with its ROS 2 message
  definition (schema encoding `ros2msg`, message encoding `cdr`), as the ROS 2
  foxglove_bridge advertises it; topics that appear later are advertised when they do;
- the bridge subscribes to a bus topic while at least one client subscribes to its
  channel, and sends each message as CDR (latched messages reach every new subscriber);
- a client may publish (`clientPublish`) on any topic, in `cdr` or `json`: the message is
  decoded into the topic's type and published on the bus (teleop on `/cmd_vel`, goals on
  `/move_base_simple/goal`); a message that does not decode is dropped with a warning
  that names the topic, and the client is told through a status message;
- bus services of known types are offered (`services`): a call in `cdr` or `json` is
  answered in the same encoding, a failure with the handler's error;
- `package://` mesh URIs of the robot's description are served through the protocol's
  asset fetch (`assets`), limited to the mesh files the loaded robot uses;
- who may connect follows the rosbridge rules (robotrial.ros.rosbridge.access): browser
  pages only from allowed origins, and with a token, `?token=` in the URL.

The `foxglove-sdk` package's server is not used: its versions on PyPI speak only the
newer `foxglove.sdk.v1` subprotocol, which Lichtblick and `@foxglove/ws-protocol` do not
offer, and it has no hook to check a browser's Origin.

Types unknown to robotrial.msgs (a rosbridge client's own dict messages) are not
advertised: they have no definition to give.
"""

from __future__ import annotations

import asyncio
import itertools
import json
import logging
import struct
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, urlsplit

from websockets.asyncio.server import Server, ServerConnection, serve
from websockets.exceptions import ConnectionClosed
from websockets.http11 import Request, Response

from robotrial.geometry import Mesh
from robotrial.model.packages import PackageResolver
from robotrial.model.robot import ModelError, RobotModel
from robotrial.msgs import Message, MessageError, ServiceType, cdr, lookup_message, lookup_service
from robotrial.msgs.core import full_definition
from robotrial.ros.bus import Bus, BusError, Node, Publisher, Subscription
from robotrial.ros.recorder import deserialize
from robotrial.ros.rosbridge.access import Access

log = logging.getLogger(__name__)

DEFAULT_PORT = 8765
SUBPROTOCOL = "foxglove.websocket.v1"
SCHEMA_ENCODING = "ros2msg"
MESSAGE_ENCODING = "cdr"
CLIENT_ENCODINGS = ("cdr", "json")


MESSAGE_DATA = 0x01  # server: subscription id, receive time, payload; client: channel id, payload
SERVICE_CALL_REQUEST = 0x02  # client: service id, call id, encoding, payload
SERVICE_CALL_RESPONSE = 0x03  # server: the same layout
FETCH_ASSET_RESPONSE = 0x04
TIME = 0x02  # server: the bus's time (ns), for clients of the "time" capability
TIME_PERIOD = 0.1  # s between Time messages
SERVICE_TIMEOUT = 120.0  # s a service call may take (planning can be slow)
STATUS_INFO, STATUS_WARNING, STATUS_ERROR = 0, 1, 2
QUEUE_LIMIT = 256  # frames waiting per client; a slow client misses data beyond it


def decode_client_message(data: bytes, encoding: str, cls: type[Message], topic: str) -> Message:
    """A client-published message in `encoding` ("cdr" or "json") as a `cls` instance;
    MessageError naming the topic when the bytes do not hold one."""
    if encoding == "json":
        try:
            obj = json.loads(data)
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise MessageError(f"{topic}: the JSON message does not parse: {exc}") from None
        return cls.from_dict(obj, topic)
    if encoding == "cdr":
        try:
            return deserialize(data, cls.__ros_type__, "ros2")
        except Exception as exc:  # rosbags raises struct/index/value errors on short data
            raise MessageError(
                f"{topic}: the CDR bytes are not a {cls.__ros_type__}: {exc}"
            ) from None
    raise MessageError(
        f"{topic}: message encoding {encoding!r} is not supported (use {CLIENT_ENCODINGS})"
    )


class MeshAssets:
    """The `package://` (and file) URIs a robot's meshes come from, resolved as the URDF
    loader resolved them: the asset fetch serves these files and nothing else."""

    def __init__(self, robot: RobotModel | None) -> None:
        self._files: set[Path] = set()
        self._resolver: PackageResolver | None = None
        if robot is None or not robot.source or not Path(robot.source).is_file():
            return
        for link in robot.links:
            for shape in [v.geometry for v in link.visuals] + [c.geometry for c in link.collisions]:
                if isinstance(shape, Mesh) and shape.filename:
                    self._files.add(Path(shape.filename).resolve())
        self._resolver = PackageResolver.create(Path(robot.source).parent)

    def fetch(self, uri: str) -> bytes | None:
        """The bytes of a mesh file of the robot named by `uri`, or None."""
        if self._resolver is None or not self._files:
            return None
        try:
            path = self._resolver.resolve(uri).resolve()
        except (ModelError, OSError, ValueError):
            return None
        if path not in self._files:
            log.warning("foxglove: asset %s is not a mesh of the robot; refused", uri)
            return None
        try:
            return path.read_bytes()
        except OSError:
            return None


@dataclass(eq=False)
class _Client:
    """One connected client: its socket, its send queue, what it subscribed and advertised."""

    ws: ServerConnection
    queue: asyncio.Queue
    subscriptions: dict[int, str] = field(default_factory=dict)  # subscription id -> topic
    channels: dict[int, dict[str, Any]] = field(default_factory=dict)  # its advertised ones
    calls: set[asyncio.Task] = field(default_factory=set)  # service calls under way

    def put(self, frame: str | bytes, data: bool = False) -> None:
        """Queue a frame (in the server's loop). When the queue is full, a data frame is
        dropped, and a control frame takes the place of the oldest frame."""
        if self.queue.full():
            if not data:
                self.queue.get_nowait()  # a control message outranks the oldest frame
            else:
                return
        self.queue.put_nowait(frame)


@dataclass(eq=False)
class _Channel:
    id: int
    topic: str
    cls: type[Message]
    subscribers: set[tuple[_Client, int]] = field(default_factory=set)
    bus_subscription: Subscription | None = None

    def advertisement(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "topic": self.topic,
            "encoding": MESSAGE_ENCODING,
            "schemaName": self.cls.__ros_type__,
            "schema": full_definition(self.cls),
            "schemaEncoding": SCHEMA_ENCODING,
        }


def _message_definition(cls: type[Message]) -> dict[str, str]:
    return {
        "encoding": MESSAGE_ENCODING,
        "schemaName": cls.__ros_type__,
        "schemaEncoding": SCHEMA_ENCODING,
        "schema": full_definition(cls),
    }


@dataclass(eq=False)
class _Service:
    id: int
    name: str
    srv: ServiceType

    def advertisement(self) -> dict[str, Any]:
        request, response = self.srv.Request, self.srv.Response
        return {
            "id": self.id,
            "name": self.name,
            "type": self.srv.name,
            "request": _message_definition(request),
            "response": _message_definition(response),
            "requestSchema": full_definition(request),  # for clients of the older spec
            "responseSchema": full_definition(response),
        }


def encode_response(msg: Message, encoding: str) -> bytes:
    """A service response in the encoding its request came in."""
    if encoding == "json":
        return json.dumps(msg.to_dict()).encode()
    return cdr.serialize(msg)


class FoxgloveBridge(Node):
    """A Foxglove WebSocket server on `host`:`port` showing and driving `bus`.

    `port` 0 picks a free port (`port` tells which once started). `robot`: the loaded
    robot, whose mesh files the 3D panel may fetch. `access`: who may connect (default:
    clients without an Origin and pages of this machine). `scan_period`: how often (s)
    the bus is checked for new topics and services. OSError when the port cannot be opened.
    """

    def __init__(
        self,
        bus: Bus,
        *,
        host: str = "127.0.0.1",
        port: int = DEFAULT_PORT,
        robot: RobotModel | None = None,
        access: Access | None = None,
        scan_period: float = 0.5,
        name: str = "/foxglove_bridge",
    ) -> None:
        super().__init__(bus, bus.unique_node_name(name))
        self.host = host
        self.access = access or Access(listen_host=host)
        self._assets = MeshAssets(robot)
        self._lock = threading.RLock()
        self._ids = itertools.count(1)
        self._channels: dict[str, _Channel] = {}
        self._by_id: dict[int, _Channel] = {}
        self._services: dict[str, _Service] = {}
        self._services_by_id: dict[int, _Service] = {}
        self._clients: set[_Client] = set()
        self._publishers: dict[str, Publisher] = {}
        self._session = str(time.time_ns())
        self._loop = asyncio.new_event_loop()
        self._server: Server | None = None
        self._started = threading.Event()
        self._error: BaseException | None = None
        self._thread = threading.Thread(
            target=self._run, args=(port,), name="foxglove-bridge", daemon=True
        )
        self._thread.start()
        self._started.wait()
        if self._error is not None:
            self._thread.join(timeout=2)
            super().destroy()
            raise OSError(
                f"the Foxglove server cannot listen on {host}:{port}: {self._error}"
            ) from None
        self.advertise_new_topics()
        self.create_timer(scan_period, self.advertise_new_topics)
        self.advertise_services()
        self.create_timer(scan_period, self.advertise_services)
        self.create_timer(TIME_PERIOD, self.send_time)

    # --- the server's thread ------------------------------------------------------------

    def _run(self, port: int) -> None:
        asyncio.set_event_loop(self._loop)
        try:
            self._server = self._loop.run_until_complete(self._open(port))
        except BaseException as exc:
            self._error = exc
            self._started.set()
            self._loop.close()
            return
        self._started.set()
        try:
            self._loop.run_until_complete(self._server.wait_closed())
        finally:
            self._loop.close()

    async def _open(self, port: int) -> Server:
        return await serve(
            self._serve_client,
            self.host,
            port,
            subprotocols=[SUBPROTOCOL],  # type: ignore[list-item]
            process_request=self._check_request,
            compression=None,
            max_size=16 * 2**20,
        )

    @property
    def port(self) -> int:
        """The TCP port the server listens on."""
        assert self._server is not None
        return self._server.sockets[0].getsockname()[1]

    @property
    def url(self) -> str:
        """The address a client on this machine opens (loopback when listening on all)."""
        shown = "127.0.0.1" if self.host in ("0.0.0.0", "::", "") else self.host
        shown = f"[{shown}]" if ":" in shown else shown
        return f"ws://{shown}:{self.port}"

    def _check_request(self, conn: ServerConnection, request: Request) -> Response | None:
        headers = {k.lower(): v for k, v in request.headers.raw_items()}
        refusal = self.access.host_refusal(headers)
        if refusal is not None:
            log.warning("foxglove: %s", refusal)
            return conn.respond(400, refusal + "\n")
        if not self.access.origin_allowed(headers):
            log.warning("foxglove: %s", self.access.refusal(headers))
            return conn.respond(403, self.access.refusal(headers) + "\n")
        query = {k: v[0] for k, v in parse_qs(urlsplit(request.path).query).items()}
        if not self.access.token_ok(self.access.request_token(headers, query)):
            return conn.respond(401, "a token is needed: connect to ws://HOST:PORT/?token=TOKEN\n")
        return None

    async def _serve_client(self, ws: ServerConnection) -> None:
        client = _Client(ws, asyncio.Queue(QUEUE_LIMIT))
        writer = asyncio.create_task(self._write(client))
        with self._lock:
            self._clients.add(client)
            channels = [c.advertisement() for c in self._channels.values()]
            services = [v.advertisement() for v in self._services.values()]
        client.put(
            json.dumps(
                {
                    "op": "serverInfo",
                    "name": "robotrial",
                    "capabilities": ["clientPublish", "services", "assets", "time"],
                    "supportedEncodings": list(CLIENT_ENCODINGS),
                    "metadata": {},
                    "sessionId": self._session,
                }
            )
        )
        if channels:
            client.put(json.dumps({"op": "advertise", "channels": channels}))
        if services:
            client.put(json.dumps({"op": "advertiseServices", "services": services}))
        try:
            async for frame in ws:
                try:
                    if isinstance(frame, bytes):
                        self._on_binary(client, frame)
                    else:
                        self._on_text(client, frame)
                except (MessageError, ValueError, KeyError, TypeError, struct.error) as exc:
                    log.warning("foxglove: client %s: %s", ws.remote_address, exc)
                    self._status(client, STATUS_WARNING, str(exc))
        except ConnectionClosed:
            pass
        finally:
            writer.cancel()
            for task in list(client.calls):
                task.cancel()
            self._forget(client)

    async def _write(self, client: _Client) -> None:
        try:
            while True:
                await client.ws.send(await client.queue.get())
        except (ConnectionClosed, asyncio.CancelledError):
            pass

    def _status(self, client: _Client, level: int, message: str) -> None:
        client.put(json.dumps({"op": "status", "level": level, "message": message}))

    # --- what clients send --------------------------------------------------------------

    def _on_text(self, client: _Client, frame: str) -> None:
        try:
            msg = json.loads(frame)
        except json.JSONDecodeError as exc:
            raise ValueError(f"a text frame that is not JSON: {exc}") from None
        op = msg.get("op") if isinstance(msg, dict) else None
        if op == "subscribe":
            for sub in msg["subscriptions"]:
                self._subscribe(client, int(sub["id"]), int(sub["channelId"]))
        elif op == "unsubscribe":
            for sub_id in msg["subscriptionIds"]:
                self._unsubscribe(client, int(sub_id))
        elif op == "advertise":
            for ch in msg["channels"]:
                client.channels[int(ch["id"])] = ch
        elif op == "unadvertise":
            for ch_id in msg["channelIds"]:
                client.channels.pop(int(ch_id), None)
        elif op == "fetchAsset":
            self._fetch_asset(client, str(msg["uri"]), int(msg["requestId"]))
        else:
            raise ValueError(f"operation {op!r} is not supported by this server")

    def _on_binary(self, client: _Client, frame: bytes) -> None:
        if len(frame) >= 13 and frame[0] == SERVICE_CALL_REQUEST:
            self._call_service(client, frame)
            return
        if len(frame) < 5 or frame[0] != MESSAGE_DATA:
            raise ValueError(f"binary frame with opcode {frame[:1].hex()} is not supported")
        (channel_id,) = struct.unpack_from("<I", frame, 1)
        ch = client.channels.get(channel_id)
        if ch is None:
            raise ValueError(f"message on channel {channel_id}, which the client never advertised")
        topic = str(ch["topic"])
        pub = self._client_publisher(topic, str(ch.get("schemaName", "")))
        assert pub.msg_class is not None
        pub.publish(decode_client_message(frame[5:], str(ch["encoding"]), pub.msg_class, topic))

    def _call_service(self, client: _Client, frame: bytes) -> None:
        service_id, call_id, n = struct.unpack_from("<III", frame, 1)
        encoding = frame[13 : 13 + n].decode("utf-8", "replace")
        payload = frame[13 + n :]
        service = self._services_by_id.get(service_id)
        if service is None:
            self._call_failed(client, service_id, call_id, f"there is no service {service_id}")
            return
        try:
            request = decode_client_message(payload, encoding, service.srv.Request, service.name)
        except MessageError as exc:
            self._call_failed(client, service_id, call_id, str(exc))
            return
        task = self._loop.create_task(self._answer(client, service, call_id, encoding, request))
        client.calls.add(task)
        task.add_done_callback(client.calls.discard)

    async def _answer(
        self, client: _Client, service: _Service, call_id: int, encoding: str, request: Any
    ) -> None:
        try:
            response = await self.bus.call_async(service.name, request, timeout=SERVICE_TIMEOUT)
            payload = encode_response(response, encoding)
        except (BusError, MessageError, TimeoutError) as exc:
            self._call_failed(client, service.id, call_id, str(exc))
            return
        head = struct.pack("<BIII", SERVICE_CALL_RESPONSE, service.id, call_id, len(encoding))
        client.put(head + encoding.encode() + payload)

    def _call_failed(self, client: _Client, service_id: int, call_id: int, why: str) -> None:
        log.warning("foxglove: service call %s failed: %s", service_id, why)
        failure = {
            "op": "serviceCallFailure",
            "serviceId": service_id,
            "callId": call_id,
            "message": why,
        }
        client.put(json.dumps(failure))

    def _fetch_asset(self, client: _Client, uri: str, request_id: int) -> None:
        data = self._assets.fetch(uri)
        if data is None:
            error = f"{uri}: not a mesh of the loaded robot".encode()
            frame = struct.pack("<BIBI", FETCH_ASSET_RESPONSE, request_id, 1, len(error)) + error
        else:
            frame = struct.pack("<BIBI", FETCH_ASSET_RESPONSE, request_id, 0, 0) + data
        client.put(frame)

    def _client_publisher(self, topic: str, schema_name: str) -> Publisher:
        """The bridge's publisher on `topic`, typed by the topic (or the client's schema
        name when the topic is new); ValueError when neither names a known type."""
        with self._lock:
            pub = self._publishers.get(topic)
            if pub is not None:
                return pub
            type_name = self.bus.topic_type(topic) or schema_name
            cls = lookup_message(type_name) if type_name else None
            if cls is None:
                raise ValueError(
                    f"{topic}: cannot publish type {type_name or '(none)'!r}: "
                    "it is not a robotrial.msgs type"
                )
            pub = self.create_publisher(topic, cls)
            self._publishers[topic] = pub
            return pub

    # --- channels and subscriptions -----------------------------------------------------

    def advertise_new_topics(self) -> list[str]:
        """Advertise every bus topic of a known type that has no channel yet; returns them."""
        added: list[_Channel] = []
        for topic, type_name in self.bus.topics().items():
            cls = lookup_message(type_name) if type_name else None
            if cls is None:
                continue
            with self._lock:
                if topic in self._channels:
                    continue
                ch = _Channel(next(self._ids), topic, cls)
                self._channels[topic] = ch
                self._by_id[ch.id] = ch
                clients = list(self._clients)
            added.append(ch)
        if added and clients:
            text = json.dumps({"op": "advertise", "channels": [c.advertisement() for c in added]})
            for client in clients:
                self._loop.call_soon_threadsafe(client.put, text)
        return [c.topic for c in added]

    def advertise_services(self) -> list[str]:
        """Offer every bus service of a known type not offered yet and withdraw those
        gone from the bus; returns the names newly offered."""
        current = self.bus.services()
        added: list[_Service] = []
        with self._lock:
            gone = [v for n, v in self._services.items() if n not in current]
            for v in gone:
                del self._services[v.name]
                del self._services_by_id[v.id]
            for name, type_name in current.items():
                srv = lookup_service(type_name)
                if srv is None or name in self._services:
                    continue
                v = _Service(next(self._ids), name, srv)
                self._services[name] = self._services_by_id[v.id] = v
                added.append(v)
            clients = list(self._clients)
        frames = []
        if gone:
            frames.append({"op": "unadvertiseServices", "serviceIds": [v.id for v in gone]})
        if added:
            frames.append(
                {"op": "advertiseServices", "services": [v.advertisement() for v in added]}
            )
        for frame in frames:
            text = json.dumps(frame)
            for client in clients:
                self._loop.call_soon_threadsafe(client.put, text)
        return [v.name for v in added]

    def channels(self) -> dict[str, str]:
        """Every advertised topic and its type name."""
        with self._lock:
            return {t: c.cls.__ros_type__ for t, c in sorted(self._channels.items())}

    def _subscribe(self, client: _Client, sub_id: int, channel_id: int) -> None:
        ch = self._by_id.get(channel_id)
        if ch is None:
            raise ValueError(f"subscribe: there is no channel {channel_id}")
        with self._lock:
            client.subscriptions[sub_id] = ch.topic
            ch.subscribers.add((client, sub_id))
            first = ch.bus_subscription is None
            if first:
                ch.bus_subscription = self.create_subscription(
                    ch.topic, None, lambda m, c=ch: self._forward(c, m)
                )
        if not first:  # what the topic latches, for this subscriber only
            once = self.bus.subscribe(
                ch.topic, lambda m: self._forward(ch, m, [(client, sub_id)]), node=self.name
            )
            once.close()

    def _unsubscribe(self, client: _Client, sub_id: int) -> None:
        topic = client.subscriptions.pop(sub_id, None)
        with self._lock:
            ch = self._channels.get(topic) if topic else None
            if ch is None:
                return
            ch.subscribers.discard((client, sub_id))
            if not ch.subscribers and ch.bus_subscription is not None:
                ch.bus_subscription.close()
                self._handles.remove(ch.bus_subscription)
                ch.bus_subscription = None

    def _forget(self, client: _Client) -> None:
        for sub_id in list(client.subscriptions):
            self._unsubscribe(client, sub_id)
        with self._lock:
            self._clients.discard(client)

    def _forward(self, ch: _Channel, msg: Any, to: list[tuple[_Client, int]] | None = None) -> None:
        """Send a bus message (any thread) to the channel's subscribers as CDR."""
        if not isinstance(msg, ch.cls):
            return
        targets = list(ch.subscribers) if to is None else to
        if not targets:
            return
        try:
            payload = cdr.serialize(msg)
        except MessageError as exc:
            log.warning("foxglove: %s: %s", ch.topic, exc)
            return
        stamp = self.bus.now_ns()
        for client, sub_id in targets:
            frame = struct.pack("<BIQ", MESSAGE_DATA, sub_id, stamp) + payload
            try:
                self._loop.call_soon_threadsafe(client.put, frame, True)
            except RuntimeError:  # the loop has closed: the server stopped
                return

    def send_time(self) -> None:
        """Tell every client the bus's time (simulated while a simulator runs), as
        foxglove_bridge does under `use_sim_time`; message timestamps use the same clock."""
        frame = struct.pack("<BQ", TIME, self.bus.now_ns())
        with self._lock:
            clients = list(self._clients)
        for client in clients:
            try:
                self._loop.call_soon_threadsafe(client.put, frame, True)
            except RuntimeError:  # the loop has closed: the server stopped
                return

    def destroy(self) -> None:
        """Stop the server and leave the bus."""
        super().destroy()
        if self._server is not None and not self._loop.is_closed():
            try:
                self._loop.call_soon_threadsafe(self._server.close)
            except RuntimeError:
                pass
        self._thread.join(timeout=5)
