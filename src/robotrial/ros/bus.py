"""The in-process ROS graph: topics, latched topics, services and the Node base (layer 4).

Everything the platform runs (simulator, planners, SLAM, rosbridge clients) meets on one
`Bus`. It plays the role of the ROS master plus intra-process transport:

- `publish` delivers a message to every subscriber at once, in the publisher's thread
  (deterministic for trials; callbacks should be quick). A subscriber whose callback is a
  coroutine function gets it scheduled on the event loop that was running when it
  subscribed, so asyncio code never runs in a foreign thread.
- Latched topics (`/tf_static`, `/map`, or `latched=True`) keep each publisher's last
  message and hand it to every later subscriber (ROS 1 latching, ROS 2 transient local).
- Services have typed requests and responses (`robotrial.msgs` service types). A handler
  may be a plain function or a coroutine function; `call` works from any thread,
  `call_async` from a coroutine (plain handlers then run in a worker thread unless
  advertised with `threaded=False`; the request is converted there too, so a large
  request never holds the event loop). A threaded handler may ask `current_call()` for
  its call's deadline and whether the caller has gone (timed out, disconnected), so
  that it can stop working for nobody.
- Types unknown to `robotrial.msgs` (a rosbridge client's own types) travel as dicts.
- One clock: `now()` is wall time until a node (the simulator) sets the bus's clock with
  `set_clock`; from then on rosapi, rosbridge's "now" and the bridges read simulated time,
  the time in the messages' headers.

All methods are thread-safe.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextvars
import inspect
import itertools
import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from robotrial.msgs import Message, MessageError, ServiceType, lookup_message, lookup_service
from robotrial.msgs.names import LATCHED_TOPICS

log = logging.getLogger(__name__)

MsgType = type[Message] | str
SrvType = ServiceType | str


class BusError(RuntimeError):
    """Misuse of the bus: a type clash, an unknown service, a closed handle."""


class ServiceNotFound(BusError):
    """No node offers the service that was called."""


class ServiceFailed(BusError):
    """The service handler raised; the message is the handler's error."""


def canonical_type(msg_type: MsgType) -> tuple[str, type[Message] | None]:
    """(type name in ROS 2 spelling when known, class or None) for a class or a name."""
    if isinstance(msg_type, type) and issubclass(msg_type, Message):
        return msg_type.__ros_type__, msg_type
    if not isinstance(msg_type, str) or not msg_type.strip():
        raise BusError(f"message type must be a Message class or a type name, got {msg_type!r}")
    cls = lookup_message(msg_type)
    return (cls.__ros_type__, cls) if cls is not None else (msg_type.strip(), None)


def canonical_service_type(srv_type: SrvType) -> tuple[str, ServiceType | None]:
    if isinstance(srv_type, ServiceType):
        return srv_type.name, srv_type
    if not isinstance(srv_type, str) or not srv_type.strip():
        raise BusError(f"service type must be a ServiceType or a name, got {srv_type!r}")
    srv = lookup_service(srv_type)
    return (srv.name, srv) if srv is not None else (srv_type.strip(), None)


def check_name(name: str, what: str = "topic") -> str:
    """A valid graph name: starts with '/', no spaces, no empty parts."""
    if not isinstance(name, str) or not name.startswith("/") or len(name) < 2:
        raise BusError(f"{what} name must start with '/', got {name!r}")
    if any(c.isspace() for c in name) or "//" in name or name.endswith("/"):
        raise BusError(f"{what} name {name!r} is not a valid ROS name")
    return name


def _coerce(cls: type[Message] | None, msg: Any, where: str) -> Any:
    if cls is None:
        if isinstance(msg, Message):
            return msg
        if not isinstance(msg, dict):
            raise MessageError(f"{where}: expected a message object, got {type(msg).__name__}")
        return msg
    if isinstance(msg, cls):
        return msg
    if isinstance(msg, Message):
        raise MessageError(f"{where}: expected {cls.__ros_type__}, got {type(msg).__ros_type__}")
    return cls.from_dict(msg, where)


@dataclass(frozen=True)
class ServiceCall:
    """One service call as its handler sees it: `deadline` (time.monotonic(); None: no
    timeout) and `abandoned`, set once the caller no longer waits for the answer."""

    deadline: float | None = None
    abandoned: threading.Event = field(default_factory=threading.Event)

    def remaining(self) -> float | None:
        """Seconds left before the deadline (None: no deadline)."""
        return None if self.deadline is None else self.deadline - time.monotonic()


_CALL: contextvars.ContextVar[ServiceCall | None] = contextvars.ContextVar("call", default=None)


def current_call() -> ServiceCall | None:
    """The call a threaded service handler is answering (None outside one)."""
    return _CALL.get()


def _loop_or_none() -> asyncio.AbstractEventLoop | None:
    try:
        return asyncio.get_running_loop()
    except RuntimeError:
        return None


@dataclass(eq=False)
class Subscription:
    """A live subscription; `close()` ends it."""

    bus: Bus
    topic: str
    callback: Callable[[Any], Any]
    node: str
    loop: asyncio.AbstractEventLoop | None = None
    closed: bool = False

    def deliver(self, msg: Any) -> None:
        if self.closed:
            return
        try:
            if self.loop is not None:
                if self.loop.is_closed():
                    return
                self.loop.call_soon_threadsafe(self._schedule, msg)
            else:
                self.callback(msg)
        except Exception:
            log.exception("subscriber of %s (node %s) failed", self.topic, self.node)

    def _schedule(self, msg: Any) -> None:
        if not self.closed:
            task = self.loop.create_task(self.callback(msg))  # type: ignore[union-attr]
            task.add_done_callback(_log_task_error)

    def close(self) -> None:
        self.bus._unsubscribe(self)


def _log_task_error(task: asyncio.Task) -> None:
    if not task.cancelled() and task.exception() is not None:
        log.error("async subscriber failed", exc_info=task.exception())


@dataclass(eq=False)
class Publisher:
    """A handle to publish on one topic with one type; `close()` unadvertises."""

    bus: Bus
    topic: str
    type_name: str
    msg_class: type[Message] | None
    latched: bool
    node: str
    closed: bool = False

    def publish(self, msg: Any) -> None:
        """Deliver `msg` (a message of this type, or its rosbridge dict) to every subscriber."""
        if self.closed:
            raise BusError(f"publisher on {self.topic} is closed")
        msg = _coerce(self.msg_class, msg, self.topic)
        self.bus._deliver(self, msg)

    def close(self) -> None:
        self.bus._unadvertise(self)


@dataclass(eq=False)
class ServiceServer:
    """An advertised service; `close()` withdraws it."""

    bus: Bus
    name: str
    type_name: str
    srv: ServiceType | None
    handler: Callable[[Any], Any]
    node: str
    threaded: bool
    loop: asyncio.AbstractEventLoop | None
    closed: bool = False

    @property
    def is_async(self) -> bool:
        return inspect.iscoroutinefunction(self.handler)

    def close(self) -> None:
        self.bus._unadvertise_service(self)


@dataclass
class _Topic:
    type_name: str
    msg_class: type[Message] | None
    latched: bool
    publishers: list[Publisher] = field(default_factory=list)
    subscribers: tuple[Subscription, ...] = ()
    last: dict[int, Any] = field(default_factory=dict)  # id(publisher) -> latched msg


class Bus:
    """Topics, services, nodes and parameters of one robotrial process."""

    def __init__(self, latched_topics: frozenset[str] | set[str] = LATCHED_TOPICS) -> None:
        self._lock = threading.RLock()
        self._topics: dict[str, _Topic] = {}
        self._services: dict[str, ServiceServer] = {}
        self._nodes: dict[str, Node] = {}
        self._latched_names = frozenset(latched_topics)
        self._anonymous: dict[str, Publisher] = {}
        self.params: dict[str, Any] = {}
        self.actions: dict[str, Any] = {}  # name -> robotrial.ros.actions.ActionServer
        self._clock: Callable[[], float] | None = None

    # ------------------------------------------------------------ time

    def set_clock(self, clock: Callable[[], float] | None) -> None:
        """Make `clock()` (s, e.g. a simulation's time) the bus's time; None: wall time."""
        self._clock = clock

    def now(self) -> float:
        """The bus's time (s): the clock set by `set_clock`, else wall time."""
        clock = self._clock
        return clock() if clock is not None else time.time()

    def now_ns(self) -> int:
        clock = self._clock
        return round(clock() * 1e9) if clock is not None else time.time_ns()

    # ------------------------------------------------------------ topics

    def advertise(
        self, topic: str, msg_type: MsgType, *, latched: bool | None = None, node: str = "/bus"
    ) -> Publisher:
        """A publisher on `topic`; the topic's type is fixed by its first user."""
        check_name(topic)
        type_name, cls = canonical_type(msg_type)
        with self._lock:
            t = self._topic(topic, type_name, cls)
            is_latched = t.latched if latched is None else latched
            t.latched = t.latched or is_latched
            pub = Publisher(self, topic, t.type_name, t.msg_class, is_latched, node)
            t.publishers.append(pub)
            return pub

    def publish(self, topic: str, msg: Any, msg_type: MsgType | None = None) -> None:
        """Publish without keeping a publisher: the type comes from the message (or
        `msg_type`, or the topic's existing type)."""
        with self._lock:
            pub = self._anonymous.get(topic)
            if pub is None or pub.closed:
                if msg_type is None:
                    if isinstance(msg, Message):
                        msg_type = type(msg)
                    elif topic in self._topics:
                        msg_type = self._topics[topic].type_name
                    else:
                        raise BusError(f"publish on {topic}: the message type is not known")
                pub = self.advertise(topic, msg_type)
                self._anonymous[topic] = pub
        pub.publish(msg)

    def subscribe(
        self,
        topic: str,
        callback: Callable[[Any], Any],
        msg_type: MsgType | None = None,
        *,
        node: str = "/bus",
    ) -> Subscription:
        """Call `callback(msg)` for every message on `topic` (and at once with the latched
        messages). A coroutine function callback runs on the current event loop."""
        check_name(topic)
        loop = None
        if inspect.iscoroutinefunction(callback):
            loop = _loop_or_none()
            if loop is None:
                raise BusError(f"subscribe to {topic}: an async callback needs a running loop")
        sub = Subscription(self, topic, callback, node, loop)
        with self._lock:
            if msg_type is not None:
                type_name, cls = canonical_type(msg_type)
                t = self._topic(topic, type_name, cls)
            else:
                t = self._topics.get(topic)
                if t is None:
                    t = self._topics[topic] = _Topic("", None, topic in self._latched_names)
            t.subscribers = (*t.subscribers, sub)
            latched = list(t.last.values())
        for msg in latched:
            sub.deliver(msg)
        return sub

    def topic_type(self, topic: str) -> str:
        """The topic's type name ("" when unknown or no such topic)."""
        with self._lock:
            t = self._topics.get(topic)
            return t.type_name if t else ""

    def is_latched(self, topic: str) -> bool:
        """Whether late subscribers of `topic` get its last messages (ROS 1 latched,
        ROS 2 transient local)."""
        with self._lock:
            t = self._topics.get(topic)
            return t.latched if t else topic in self._latched_names

    def topics(self) -> dict[str, str]:
        """Every topic with a publisher or a subscriber, and its type name."""
        with self._lock:
            return {
                name: t.type_name
                for name, t in sorted(self._topics.items())
                if t.publishers or t.subscribers
            }

    def publishers(self, topic: str) -> list[str]:
        with self._lock:
            t = self._topics.get(topic)
            return sorted({p.node for p in t.publishers}) if t else []

    def subscribers(self, topic: str) -> list[str]:
        with self._lock:
            t = self._topics.get(topic)
            return sorted({s.node for s in t.subscribers}) if t else []

    def subscriber_count(self, topic: str) -> int:
        with self._lock:
            t = self._topics.get(topic)
            return len(t.subscribers) if t else 0

    def _topic(self, topic: str, type_name: str, cls: type[Message] | None) -> _Topic:
        t = self._topics.get(topic)
        if t is None:
            t = _Topic(type_name, cls, topic in self._latched_names)
            self._topics[topic] = t
        elif not t.type_name:
            t.type_name, t.msg_class = type_name, cls
        elif t.type_name != type_name:
            raise BusError(f"topic {topic} has type {t.type_name}, not {type_name}")
        return t

    def _deliver(self, pub: Publisher, msg: Any) -> None:
        t = self._topics.get(pub.topic)
        if t is None:
            return
        if pub.latched:
            with self._lock:
                t.last[id(pub)] = msg
                subs = t.subscribers
        else:
            subs = t.subscribers
        for sub in subs:
            sub.deliver(msg)

    def _unsubscribe(self, sub: Subscription) -> None:
        with self._lock:
            sub.closed = True
            t = self._topics.get(sub.topic)
            if t is not None:
                t.subscribers = tuple(s for s in t.subscribers if s is not sub)
                self._maybe_drop(sub.topic, t)

    def _unadvertise(self, pub: Publisher) -> None:
        with self._lock:
            pub.closed = True
            t = self._topics.get(pub.topic)
            if t is not None:
                t.publishers = [p for p in t.publishers if p is not pub]
                t.last.pop(id(pub), None)
                self._maybe_drop(pub.topic, t)

    def _maybe_drop(self, name: str, t: _Topic) -> None:
        if not t.publishers and not t.subscribers:
            del self._topics[name]

    # ------------------------------------------------------------ services

    def advertise_service(
        self,
        name: str,
        srv_type: SrvType,
        handler: Callable[[Any], Any],
        *,
        node: str = "/bus",
        threaded: bool = True,
    ) -> ServiceServer:
        """Offer service `name`: `handler(request) -> response` (plain or async).

        An async handler runs on the loop running now. `threaded=False` lets a quick
        plain handler run inline even when called from a coroutine.
        """
        check_name(name, "service")
        type_name, srv = canonical_service_type(srv_type)
        loop = _loop_or_none() if inspect.iscoroutinefunction(handler) else None
        if inspect.iscoroutinefunction(handler) and loop is None:
            raise BusError(f"service {name}: an async handler needs a running event loop")
        server = ServiceServer(self, name, type_name, srv, handler, node, threaded, loop)
        with self._lock:
            if name in self._services:
                raise BusError(f"service {name} is already offered by {self._services[name].node}")
            self._services[name] = server
        return server

    def services(self) -> dict[str, str]:
        """Every offered service and its type name."""
        with self._lock:
            return {n: s.type_name for n, s in sorted(self._services.items())}

    def service(self, name: str) -> ServiceServer | None:
        with self._lock:
            return self._services.get(name)

    def _unadvertise_service(self, server: ServiceServer) -> None:
        with self._lock:
            server.closed = True
            if self._services.get(server.name) is server:
                del self._services[server.name]

    def _prepare(self, name: str, request: Any) -> tuple[ServiceServer, Any]:
        server = self.service(name)
        if server is None:
            raise ServiceNotFound(f"service {name} is not offered")
        cls = server.srv.Request if server.srv else None
        return server, _coerce(cls, request if request is not None else {}, f"{name} request")

    @staticmethod
    def _finish(server: ServiceServer, response: Any) -> Any:
        if server.srv is None:
            return response if response is not None else {}
        return _coerce(server.srv.Response, response if response is not None else {}, server.name)

    def call(self, name: str, request: Any = None, timeout: float | None = None) -> Any:
        """Call a service from plain (non-async) code and wait for the response."""
        server, req = self._prepare(name, request)
        if server.is_async:
            assert server.loop is not None
            if _loop_or_none() is server.loop:
                raise BusError(f"call {name}: from a coroutine on its loop, use call_async")
            fut = asyncio.run_coroutine_threadsafe(server.handler(req), server.loop)
            try:
                resp = fut.result(timeout)
            except concurrent.futures.TimeoutError:
                fut.cancel()
                raise TimeoutError(f"service {name} did not answer within {timeout} s") from None
            except (BusError, MessageError, TimeoutError):
                raise
            except Exception as exc:
                raise ServiceFailed(f"service {name} failed: {exc}") from exc
        else:
            try:
                resp = server.handler(req)
            except (BusError, MessageError):
                raise
            except Exception as exc:
                raise ServiceFailed(f"service {name} failed: {exc}") from exc
        return self._finish(server, resp)

    async def call_async(self, name: str, request: Any = None, timeout: float | None = None) -> Any:
        """Call a service from a coroutine without blocking the event loop. A threaded
        handler sees the call's deadline and, once the caller stops waiting (timeout or
        cancellation), its `abandoned` event set (`current_call()`)."""
        server = self.service(name)
        if server is not None and server.threaded and not server.is_async:
            return await self._call_threaded(server, request, timeout)
        server, req = self._prepare(name, request)
        loop = asyncio.get_running_loop()
        try:
            if server.is_async:
                if server.loop is loop:
                    coro = server.handler(req)
                else:
                    coro = asyncio.wrap_future(
                        asyncio.run_coroutine_threadsafe(server.handler(req), server.loop)  # type: ignore[arg-type]
                    )
                resp = await asyncio.wait_for(coro, timeout)
            else:
                resp = server.handler(req)
        except TimeoutError:
            raise TimeoutError(f"service {name} did not answer within {timeout} s") from None
        except (BusError, MessageError, asyncio.CancelledError):
            raise
        except Exception as exc:
            raise ServiceFailed(f"service {name} failed: {exc}") from exc
        return self._finish(server, resp)

    async def _call_threaded(
        self, server: ServiceServer, request: Any, timeout: float | None
    ) -> Any:
        call = ServiceCall(None if timeout is None else time.monotonic() + timeout)

        def answer() -> Any:
            _CALL.set(call)
            _, req = self._prepare(server.name, request)
            try:
                return self._finish(server, server.handler(req))
            except (BusError, MessageError):
                raise
            except Exception as exc:
                raise ServiceFailed(f"service {server.name} failed: {exc}") from exc

        loop = asyncio.get_running_loop()
        work = loop.run_in_executor(None, contextvars.copy_context().run, answer)
        try:
            return await asyncio.wait_for(work, timeout)
        except TimeoutError:
            call.abandoned.set()
            raise TimeoutError(f"service {server.name} did not answer within {timeout} s") from None
        except asyncio.CancelledError:
            call.abandoned.set()
            raise

    # ------------------------------------------------------------ nodes

    def nodes(self) -> list[str]:
        with self._lock:
            return sorted(self._nodes)

    def node(self, name: str) -> Node | None:
        with self._lock:
            return self._nodes.get(name)

    def node_details(self, name: str) -> dict[str, list[str]]:
        """What a node publishes, subscribes to and offers (by the node name it used)."""
        with self._lock:
            pubs = sorted(
                {n for n, t in self._topics.items() for p in t.publishers if p.node == name}
            )
            subs = sorted(
                {n for n, t in self._topics.items() for s in t.subscribers if s.node == name}
            )
            srvs = sorted(n for n, s in self._services.items() if s.node == name)
        return {"publishing": pubs, "subscribing": subs, "services": srvs}

    def _add_node(self, node: Node) -> None:
        with self._lock:
            if node.name in self._nodes:
                raise BusError(f"a node named {node.name} already exists")
            self._nodes[node.name] = node

    def _remove_node(self, node: Node) -> None:
        with self._lock:
            if self._nodes.get(node.name) is node:
                del self._nodes[node.name]

    def unique_node_name(self, base: str) -> str:
        """`base`, or `base_2`, `base_3`... whichever is free."""
        with self._lock:
            if base not in self._nodes:
                return base
            for i in itertools.count(2):
                if f"{base}_{i}" not in self._nodes:
                    return f"{base}_{i}"
        raise AssertionError("unreachable")


class Timer:
    """Calls `callback()` every `period` seconds in its own daemon thread until `cancel()`."""

    def __init__(self, period: float, callback: Callable[[], Any], name: str = "timer") -> None:
        if not period > 0:
            raise BusError(f"timer period must be positive, got {period}")
        self.period = period
        self._callback = callback
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(self.period):
            try:
                self._callback()
            except Exception:
                log.exception("timer %s failed", self._thread.name)

    def cancel(self) -> None:
        self._stop.set()
        if threading.current_thread() is not self._thread:
            self._thread.join(timeout=1.0)


class Node:
    """Base of everything that lives on the bus: it owns publishers, subscriptions,
    services and timers, and `destroy()` (or leaving a `with` block) removes them all.

    An algorithm node subclasses this, creates its interfaces in `__init__`, and calls a
    plain algorithm object in its callbacks.
    """

    def __init__(self, bus: Bus, name: str) -> None:
        if not name.startswith("/"):
            name = "/" + name
        check_name(name, "node")
        self.bus = bus
        self.name = name
        self._handles: list[Publisher | Subscription | ServiceServer | Timer] = []
        bus._add_node(self)

    def create_publisher(
        self, topic: str, msg_type: MsgType, *, latched: bool | None = None
    ) -> Publisher:
        pub = self.bus.advertise(topic, msg_type, latched=latched, node=self.name)
        self._handles.append(pub)
        return pub

    def create_subscription(
        self, topic: str, msg_type: MsgType | None, callback: Callable[[Any], Any]
    ) -> Subscription:
        sub = self.bus.subscribe(topic, callback, msg_type, node=self.name)
        self._handles.append(sub)
        return sub

    def create_service(
        self,
        name: str,
        srv_type: SrvType,
        handler: Callable[[Any], Any],
        *,
        threaded: bool = True,
    ) -> ServiceServer:
        server = self.bus.advertise_service(
            name, srv_type, handler, node=self.name, threaded=threaded
        )
        self._handles.append(server)
        return server

    def create_timer(self, period: float, callback: Callable[[], Any]) -> Timer:
        timer = Timer(period, callback, name=f"{self.name} timer")
        self._handles.append(timer)
        return timer

    def call(self, service: str, request: Any = None, timeout: float | None = None) -> Any:
        return self.bus.call(service, request, timeout)

    def destroy(self) -> None:
        """Close every publisher, subscription, service and timer of this node."""
        handles, self._handles = self._handles, []
        for h in reversed(handles):
            if isinstance(h, Timer):
                h.cancel()
            else:
                h.close()
        self.bus._remove_node(self)

    def __enter__(self) -> Node:
        return self

    def __exit__(self, *exc: object) -> None:
        self.destroy()
