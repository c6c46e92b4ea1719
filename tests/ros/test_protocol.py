"""Every rosbridge operation, driven in-process through `Session` (no socket).

A `Client` feeds frames to a real session and collects the frames the session writes,
so these tests see exactly what a WebSocket client would.
"""

from __future__ import annotations

import asyncio
import json
import threading
from typing import Any

import pytest
from rosbags.typesys import Stores, get_typestore

from robotrial.msgs import cbor
from robotrial.msgs.geometry_msgs import TransformStamped
from robotrial.msgs.sensor_msgs import JointState
from robotrial.msgs.std_msgs import Header, String
from robotrial.msgs.tf2_msgs import TFMessage
from robotrial.ros.bus import Bus
from robotrial.ros.rosbridge import Limits, RosbridgeServer
from robotrial.ros.rosbridge.encoding import png_unpack


def decode(frame: str | bytes) -> dict:
    return json.loads(frame) if isinstance(frame, str) else cbor.loads(frame)


class Client:
    """One rosbridge client wired straight to a session."""

    def __init__(self, server: RosbridgeServer) -> None:
        self.inbox: asyncio.Queue = asyncio.Queue()

        async def send(frame: str | bytes) -> None:
            await self.inbox.put(frame)

        self.session = server.open_session(send)

    async def send(self, op: Any) -> None:
        await self.session.receive(op if isinstance(op, str | bytes) else json.dumps(op))

    async def frame(self, timeout: float = 2.0) -> str | bytes:
        return await asyncio.wait_for(self.inbox.get(), timeout)

    async def recv(self, timeout: float = 2.0) -> dict:
        return decode(await self.frame(timeout))

    async def recv_op(self, op: str, timeout: float = 2.0) -> dict:
        while True:
            msg = await self.recv(timeout)
            if msg.get("op") == op:
                return msg

    async def drain(self, wait: float = 0.05) -> list[dict]:
        await asyncio.sleep(wait)
        out = []
        while not self.inbox.empty():
            out.append(decode(self.inbox.get_nowait()))
        return out

    async def close(self) -> None:
        await self.session.close()


def run(coro_fn) -> Any:
    return asyncio.run(coro_fn())


def test_advertise_publish_subscribe_unsubscribe() -> None:
    async def main() -> None:
        bus = Bus()
        server = RosbridgeServer(bus)
        own = bus.topics()  # the server's own (tf2_web_republisher's goal and cancel)
        a, b = Client(server), Client(server)
        await a.send(
            {"op": "subscribe", "id": "s1", "topic": "/chatter", "type": "std_msgs/msg/String"}
        )
        await b.send(
            {"op": "advertise", "id": "a1", "topic": "/chatter", "type": "std_msgs/String"}
        )
        await b.send({"op": "publish", "topic": "/chatter", "msg": {"data": "hi"}})
        got = await a.recv_op("publish")
        assert got == {"op": "publish", "topic": "/chatter", "msg": {"data": "hi"}}
        assert bus.topics() == {**own, "/chatter": "std_msgs/msg/String"}
        assert bus.publishers("/chatter") == [b.session.name]

        await a.send({"op": "unsubscribe", "id": "s1", "topic": "/chatter"})
        await b.send({"op": "publish", "topic": "/chatter", "msg": {"data": "again"}})
        assert await a.drain() == []
        await b.send({"op": "unadvertise", "topic": "/chatter"})
        assert bus.topics() == own
        await a.close()
        await b.close()
        assert server.sessions == set()

    run(main)


def test_dialect_follows_the_type_spelling() -> None:
    async def main() -> None:
        bus = Bus()
        server = RosbridgeServer(bus)
        ros1, ros2, plain = Client(server), Client(server), Client(server)
        bus.advertise("/joint_states", JointState)
        await ros1.send(
            {"op": "subscribe", "topic": "/joint_states", "type": "sensor_msgs/JointState"}
        )
        await ros2.send(
            {"op": "subscribe", "topic": "/joint_states", "type": "sensor_msgs/msg/JointState"}
        )
        await plain.send({"op": "subscribe", "topic": "/joint_states"})
        bus.publish("/joint_states", JointState(header=Header(frame_id="base"), name=["j"]))
        m1, m2, m3 = [await c.recv_op("publish") for c in (ros1, ros2, plain)]
        assert m1["msg"]["header"] == {
            "seq": 0,
            "stamp": {"secs": 0, "nsecs": 0},
            "frame_id": "base",
        }
        assert m2["msg"]["header"] == {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": "base"}
        assert m3["msg"]["header"] == m2["msg"]["header"]

    run(main)


def test_publish_from_another_thread_reaches_clients() -> None:
    async def main() -> None:
        bus = Bus()
        server = RosbridgeServer(bus)
        c = Client(server)
        bus.advertise("/joint_states", JointState)
        await c.send({"op": "subscribe", "topic": "/joint_states", "queue_length": 200})
        thread = threading.Thread(
            target=lambda: [
                bus.publish("/joint_states", JointState(position=[float(i)])) for i in range(100)
            ]
        )
        thread.start()
        seen = [(await c.recv_op("publish"))["msg"]["position"][0] for _ in range(100)]
        thread.join()
        assert seen == [float(i) for i in range(100)]

    run(main)


def test_latched_topics_reach_late_subscribers() -> None:
    async def main() -> None:
        bus = Bus()
        server = RosbridgeServer(bus)
        tf = TFMessage(transforms=[TransformStamped(child_frame_id="camera")])
        bus.publish("/tf_static", tf)
        c = Client(server)
        await c.send({"op": "subscribe", "topic": "/tf_static", "type": "tf2_msgs/TFMessage"})
        got = await c.recv_op("publish")
        assert got["msg"]["transforms"][0]["child_frame_id"] == "camera"
        # a client can latch its own topic
        pub = Client(server)
        await pub.send(
            {"op": "advertise", "topic": "/goal", "type": "std_msgs/String", "latch": True}
        )
        await pub.send({"op": "publish", "topic": "/goal", "msg": {"data": "kitchen"}})
        late = Client(server)
        await late.send({"op": "subscribe", "topic": "/goal"})
        assert (await late.recv_op("publish"))["msg"] == {"data": "kitchen"}

    run(main)


ERRORS = [
    ("{not json", None, "invalid JSON"),
    ("[1, 2]", None, "JSON object"),
    ({"id": "e1", "topic": "/x"}, "e1", "missing field 'op'"),
    ({"op": "teleport", "id": "e2"}, "e2", "unknown op 'teleport'"),
    ({"op": "subscribe", "id": "e3"}, "e3", "missing field 'topic'"),
    ({"op": "subscribe", "id": "e4", "topic": 5}, "e4", "'topic' must be a string"),
    ({"op": "subscribe", "id": 6, "topic": "/a", "throttle_rate": -1}, 6, "'throttle_rate'"),
    ({"op": "subscribe", "id": "e7", "topic": "/a", "compression": "zip"}, "e7", "compression"),
    ({"op": "subscribe", "id": "e8", "topic": "/a", "queue_length": "many"}, "e8", "queue_length"),
    (
        {"op": "subscribe", "id": "e9", "topic": "/joint_states", "type": "std_msgs/String"},
        "e9",
        "has type sensor_msgs/msg/JointState",
    ),
    ({"op": "publish", "id": "e10", "topic": "/nobody"}, "e10", "advertise it first"),
    (
        {"op": "publish", "id": "e11", "topic": "/joint_states", "msg": {"name": "j1"}},
        "e11",
        "/joint_states.name: expected an array",
    ),
    (
        {"op": "publish", "id": "e12", "topic": "/joint_states", "msg": {"position": [1, "x"]}},
        "e12",
        "position[1]: expected a number",
    ),
    (
        {"op": "publish", "id": "e13", "topic": "/joint_states", "msg": {"velocity_x": []}},
        "e13",
        "no field 'velocity_x'",
    ),
    (
        {"op": "advertise", "id": "e14", "topic": "/joint_states", "type": "std_msgs/String"},
        "e14",
        "has type",
    ),
    ({"op": "advertise", "id": "e15", "topic": "/t"}, "e15", "missing field 'type'"),
    (
        {"op": "advertise", "id": "e16", "topic": "not a name", "type": "std_msgs/String"},
        "e16",
        "not a valid",
    ),
    ({"op": "call_service", "id": "e17"}, "e17", "missing field 'service'"),
    ({"op": "call_service", "id": "e18", "service": "/s", "args": 3}, "e18", "'args'"),
    (
        {"op": "advertise_service", "id": "e19", "service": "/rosapi/topics", "type": "x/Y"},
        "e19",
        "already",
    ),
    ({"op": "fragment", "id": "f", "data": "x", "num": 3, "total": 2}, "f", "0 <= num < total"),
    ({"op": "png", "id": "p", "data": "bm90IGEgcG5n"}, "p", "not a valid base64 PNG"),
    ({"op": "set_level", "id": "l", "level": "loud"}, "l", "level must be one of"),
    ({"op": "service_response", "id": None}, None, "missing field 'id'"),
    (b"\xff\x00\x13garbage", None, "neither JSON nor valid CBOR"),
    (
        '{"op": "publish", "id": "deep", "msg": ' + "[" * 100 + "]" * 100 + "}",
        "deep",
        "nested deeper",
    ),
    (b"[" * 5000 + b"]" * 5000, None, "nested too deeply"),
]


@pytest.mark.parametrize(("frame", "oid", "text"), ERRORS)
def test_bad_input_gets_a_status_error_and_the_session_lives(frame, oid, text) -> None:
    async def main() -> None:
        bus = Bus()
        bus.advertise("/joint_states", JointState)
        server = RosbridgeServer(bus)
        c = Client(server)
        await c.send(frame)
        status = await c.recv_op("status")
        assert status["level"] == "error"
        assert text in status["msg"]
        assert status.get("id") == oid
        # still serving
        await c.send({"op": "call_service", "id": "ok", "service": "/rosapi/nodes"})
        resp = await c.recv_op("service_response")
        assert resp["result"] is True and c.session.name in resp["values"]["nodes"]

    run(main)


def test_oversized_message_is_refused_with_a_status() -> None:
    async def main() -> None:
        bus = Bus()
        server = RosbridgeServer(bus, limits=Limits(max_message_bytes=1000))
        c = Client(server)
        big = json.dumps({"op": "publish", "id": "big", "topic": "/x", "msg": {"data": "x" * 5000}})
        await c.send(big)
        status = await c.recv_op("status")
        assert "larger than the limit of 1000 bytes" in status["msg"]
        # fragments that add up to too much are refused as well
        for i in range(3):
            await c.send({"op": "fragment", "id": "F", "data": "y" * 400, "num": i, "total": 3})
        status = await c.recv_op("status")
        assert "larger than 1000" in status["msg"]
        assert c.session.fragments.pending() == 0

    run(main)


def test_call_service_success_and_failures() -> None:
    async def main() -> None:
        bus = Bus()

        def boom(req: Any) -> Any:
            raise RuntimeError("arm is not calibrated")

        bus.advertise_service("/calibrate", "std_srvs/srv/Trigger", boom)
        server = RosbridgeServer(bus)
        c = Client(server)
        await c.send({"op": "call_service", "id": 1, "service": "/rosapi/services"})
        ok = await c.recv_op("service_response")
        assert ok["id"] == 1 and ok["result"] is True and "/calibrate" in ok["values"]["services"]

        await c.send({"op": "call_service", "id": 2, "service": "/missing"})
        miss = await c.recv_op("service_response")
        assert miss == {
            "op": "service_response",
            "service": "/missing",
            "id": 2,
            "values": "service /missing is not offered",
            "result": False,
        }
        await c.send({"op": "call_service", "id": 3, "service": "/calibrate"})
        failed = await c.recv_op("service_response")
        assert failed["result"] is False and "arm is not calibrated" in failed["values"]
        await c.send(
            {"op": "call_service", "id": 4, "service": "/rosapi/topic_type", "args": {"topic": 3}}
        )
        bad = await c.recv_op("service_response")
        assert bad["result"] is False and "topic: expected a string" in bad["values"]
        # positional args and a relative name (as roslibjs's Param uses)
        await c.send(
            {"op": "call_service", "id": 5, "service": "rosapi/topic_type", "args": ["/x"]}
        )
        pos = await c.recv_op("service_response")
        assert pos["result"] is True and pos["service"] == "rosapi/topic_type"

    run(main)


def test_service_offered_by_a_client() -> None:
    async def main() -> None:
        bus = Bus()
        server = RosbridgeServer(bus)
        provider, caller = Client(server), Client(server)
        await provider.send(
            {"op": "advertise_service", "service": "/add", "type": "example/AddTwoInts"}
        )
        assert bus.services()["/add"] == "example/AddTwoInts"

        await caller.send(
            {"op": "call_service", "id": "c1", "service": "/add", "args": {"a": 1, "b": 2}}
        )
        request = await provider.recv_op("call_service")
        assert request["service"] == "/add" and request["args"] == {"a": 1, "b": 2}
        await provider.send(
            {
                "op": "service_response",
                "id": request["id"],
                "service": "/add",
                "values": {"sum": 3},
                "result": True,
            }
        )
        answer = await caller.recv_op("service_response")
        assert answer["id"] == "c1" and answer["values"] == {"sum": 3} and answer["result"] is True

        await caller.send({"op": "call_service", "id": "c2", "service": "/add", "args": {}})
        request = await provider.recv_op("call_service")
        await provider.send(
            {"op": "service_response", "id": request["id"], "values": "bad", "result": False}
        )
        answer = await caller.recv_op("service_response")
        assert answer["result"] is False and "bad" in answer["values"]

        # the provider vanishes while a call waits for it
        await caller.send({"op": "call_service", "id": "c3", "service": "/add", "args": {}})
        await provider.recv_op("call_service")
        await provider.close()
        answer = await caller.recv_op("service_response")
        assert (
            answer["id"] == "c3"
            and answer["result"] is False
            and "disconnected" in answer["values"]
        )
        assert "/add" not in bus.services()

        # typed services offered by a client are checked on the way back
        typed = Client(server)
        await typed.send(
            {"op": "advertise_service", "service": "/enable", "type": "std_srvs/srv/SetBool"}
        )
        await caller.send(
            {"op": "call_service", "id": "c4", "service": "/enable", "args": {"data": True}}
        )
        request = await typed.recv_op("call_service")
        assert request["args"] == {"data": True}
        await typed.send(
            {"op": "service_response", "id": request["id"], "values": {"success": "yes"}}
        )
        answer = await caller.recv_op("service_response")
        assert answer["result"] is False and "success: expected true or false" in answer["values"]
        await typed.send({"op": "unadvertise_service", "service": "/enable"})
        assert "/enable" not in bus.services()

    run(main)


def test_caller_vanishing_mid_call_is_cleaned_up() -> None:
    async def main() -> None:
        bus = Bus()
        release = threading.Event()

        def slow(req: Any) -> Any:
            release.wait(5)
            return {}

        bus.advertise_service("/slow", "std_srvs/Empty", slow)
        server = RosbridgeServer(bus)
        c = Client(server)
        await c.send({"op": "call_service", "id": "x", "service": "/slow"})
        await c.send(
            {"op": "subscribe", "topic": "/joint_states", "type": "sensor_msgs/JointState"}
        )
        await asyncio.sleep(0.05)
        assert len(c.session.calls) == 1
        await c.close()
        release.set()
        await asyncio.sleep(0.05)
        assert c.session.calls == set()
        assert server.sessions == set()
        assert bus.subscriber_count("/joint_states") == 0
        assert all(not n.startswith("/rosbridge_websocket") for n in bus.nodes())

    run(main)


def test_cbor_and_cbor_raw() -> None:
    async def main() -> None:
        bus = Bus()
        server = RosbridgeServer(bus)
        c, raw = Client(server), Client(server)
        bus.advertise("/joint_states", JointState)
        await c.send({"op": "subscribe", "topic": "/joint_states", "compression": "cbor"})
        await raw.send({"op": "subscribe", "topic": "/joint_states", "compression": "cbor-raw"})
        msg = JointState(name=["a", "b"], position=[1.5, -2.0], effort=[float("inf"), 0.0])
        bus.publish("/joint_states", msg)

        frame = await c.frame()
        assert isinstance(frame, bytes)
        decoded = cbor.loads(frame)
        assert decoded["op"] == "publish"
        assert decoded["msg"]["position"] == [1.5, -2.0]
        assert decoded["msg"]["effort"] == [float("inf"), 0.0]  # CBOR keeps non-finite floats
        assert JointState.from_dict(decoded["msg"]).name == ["a", "b"]

        r = cbor.loads(await raw.frame())
        assert set(r["msg"]) == {"secs", "nsecs", "bytes"}
        store = get_typestore(Stores.ROS2_HUMBLE)
        back = store.deserialize_cdr(r["msg"]["bytes"], "sensor_msgs/msg/JointState")
        assert back.name == ["a", "b"] and list(back.position) == [1.5, -2.0]

        # asked in the ROS 1 spelling, cbor-raw carries ROS 1 serialization
        ros1 = Client(server)
        await ros1.send(
            {
                "op": "subscribe",
                "topic": "/joint_states",
                "type": "sensor_msgs/JointState",
                "compression": "cbor-raw",
            }
        )
        bus.publish("/joint_states", msg)
        r1 = cbor.loads(await ros1.frame())
        back1 = get_typestore(Stores.ROS1_NOETIC).deserialize_ros1(
            r1["msg"]["bytes"], "sensor_msgs/msg/JointState"
        )
        assert back1.name == ["a", "b"] and back1.header.seq == 0

        # a client may speak CBOR too
        await c.send(
            cbor.dumps(
                {
                    "op": "call_service",
                    "id": 9,
                    "service": "/rosapi/topic_type",
                    "args": {"topic": "/joint_states"},
                }
            )
        )
        resp = await c.recv_op("service_response")
        assert resp["values"] == {"type": "sensor_msgs/msg/JointState"}

    run(main)


def test_png_compression_both_ways() -> None:
    async def main() -> None:
        bus = Bus()
        server = RosbridgeServer(bus)
        c = Client(server)
        await c.send(
            {
                "op": "subscribe",
                "topic": "/chatter",
                "type": "std_msgs/String",
                "compression": "png",
            }
        )
        bus.publish("/chatter", String(data="ünïcode and a long " + "x" * 500))
        frame = await c.recv()
        assert frame["op"] == "png"
        inner = json.loads(png_unpack(frame["data"]))
        assert inner["msg"]["data"].startswith("ünïcode")

        # a client may send png-packed operations too
        from robotrial.ros.rosbridge.encoding import png_pack

        op = json.dumps({"op": "call_service", "id": "png-call", "service": "/rosapi/get_time"})
        await c.send({"op": "png", "data": png_pack(op)})
        resp = await c.recv_op("service_response")
        assert resp["id"] == "png-call" and resp["result"] is True

    run(main)


def test_fragments_out_and_in() -> None:
    async def main() -> None:
        bus = Bus()
        server = RosbridgeServer(bus)
        c = Client(server)
        bus.advertise("/joint_states", JointState)
        await c.send({"op": "subscribe", "id": "js", "topic": "/joint_states", "fragment_size": 40})
        bus.publish("/joint_states", JointState(name=[f"joint_{i}" for i in range(10)]))
        pieces = [await c.recv() for _ in range(2)]
        total = pieces[0]["total"]
        pieces += [await c.recv() for _ in range(total - 2)]
        assert all(p["op"] == "fragment" and len(p["data"]) <= 40 for p in pieces)
        assert [p["num"] for p in pieces] == list(range(total))
        whole = json.loads("".join(p["data"] for p in pieces))
        assert whole["msg"]["name"][9] == "joint_9"

        # incoming fragments, out of order
        text = json.dumps({"op": "call_service", "id": "frag", "service": "/rosapi/topics"})
        parts = [text[i : i + 10] for i in range(0, len(text), 10)]
        order = list(reversed(range(len(parts))))
        for i in order:
            await c.send(
                {"op": "fragment", "id": "q", "data": parts[i], "num": i, "total": len(parts)}
            )
        resp = await c.recv_op("service_response")
        assert resp["id"] == "frag" and "/joint_states" in resp["values"]["topics"]

        # a service response can be fragmented too
        await c.send(
            {
                "op": "call_service",
                "id": "big",
                "service": "/rosapi/message_details",
                "args": {"type": "visualization_msgs/msg/Marker"},
                "fragment_size": 100,
            }
        )
        first = await c.recv()
        assert first["op"] == "fragment" and first["id"] == "big"

    run(main)


@pytest.mark.parametrize("queue_length", [0, 1])
def test_throttle_sends_the_newest_message(queue_length: int) -> None:
    """With a throttle, queue_length 0 (the default) and 1 both drop what arrives
    between two sends: the next message is the newest, not one queued long ago."""

    async def main() -> None:
        bus = Bus()
        server = RosbridgeServer(bus)
        c = Client(server)
        await c.send(
            {
                "op": "subscribe",
                "topic": "/n",
                "type": "std_msgs/Int32",
                "throttle_rate": 200,
                "queue_length": queue_length,
            }
        )
        bus.publish("/n", {"data": 0}, "std_msgs/msg/Int32")
        first = await c.recv_op("publish")
        for i in range(1, 20):
            bus.publish("/n", {"data": i}, "std_msgs/msg/Int32")
        second = await c.recv_op("publish", timeout=2.0)
        assert first["msg"]["data"] == 0
        assert second["msg"]["data"] == 19  # only the newest was kept
        assert await c.drain(0.05) == []

    run(main)


def test_slow_client_keeps_a_bounded_queue() -> None:
    async def main() -> None:
        bus = Bus()
        server = RosbridgeServer(bus)
        gate = asyncio.Event()
        got: list = []

        async def send(frame: str | bytes) -> None:
            await gate.wait()
            got.append(json.loads(frame))

        session = server.open_session(send)
        bus.advertise("/n", "std_msgs/msg/Int32")
        await session.receive(json.dumps({"op": "subscribe", "topic": "/n", "queue_length": 5}))
        await asyncio.sleep(0)
        for i in range(1000):
            bus.publish("/n", {"data": i}, "std_msgs/msg/Int32")
        sub = session.subscriptions["/n"]
        assert len(sub.queue) <= 5
        gate.set()
        await asyncio.sleep(0.1)
        data = [m["msg"]["data"] for m in got]
        assert data[-1] == 999 and len(data) <= 6
        await session.close()

    run(main)


def test_multiple_subscribe_ids_share_one_subscription() -> None:
    async def main() -> None:
        bus = Bus()
        server = RosbridgeServer(bus)
        c = Client(server)
        await c.send({"op": "subscribe", "id": "a", "topic": "/chatter", "type": "std_msgs/String"})
        await c.send({"op": "subscribe", "id": "b", "topic": "/chatter"})
        assert bus.subscriber_count("/chatter") == 1
        await c.send({"op": "unsubscribe", "id": "a", "topic": "/chatter"})
        assert bus.subscriber_count("/chatter") == 1
        await c.send({"op": "unsubscribe", "id": "b", "topic": "/chatter"})
        assert bus.subscriber_count("/chatter") == 0

    run(main)


def test_set_level_filters_status() -> None:
    async def main() -> None:
        bus = Bus()
        server = RosbridgeServer(bus)
        c = Client(server)
        await c.send({"op": "unadvertise", "id": "w", "topic": "/never"})
        assert await c.drain() == []  # a warning, below the default level
        await c.send({"op": "set_level", "level": "warning"})
        await c.send({"op": "unadvertise", "id": "w", "topic": "/never"})
        assert (await c.recv_op("status"))["level"] == "warning"
        await c.send({"op": "set_level", "level": "none"})
        await c.send({"op": "teleport"})
        assert await c.drain() == []

    run(main)


def test_rosapi_answers() -> None:
    async def main() -> None:
        bus = Bus()
        bus.advertise("/scan", "sensor_msgs/LaserScan")
        server = RosbridgeServer(bus)
        c = Client(server)

        async def call(service: str, args: dict | None = None) -> Any:
            await c.send(
                {"op": "call_service", "id": service, "service": service, "args": args or {}}
            )
            resp = await c.recv_op("service_response")
            assert resp["result"] is True, resp
            return resp["values"]

        raw = await call("/rosapi/topics_and_raw_types")
        i = raw["topics"].index("/scan")
        assert raw["types"][i] == "sensor_msgs/msg/LaserScan"
        assert "float32[] ranges" in raw["typedefs_full_text"][i]
        assert "MSG: builtin_interfaces/Time" in raw["typedefs_full_text"][i]
        assert (await call("/rosapi/topics_for_type", {"type": "sensor_msgs/LaserScan"}))[
            "topics"
        ] == ["/scan"]
        assert (await call("/rosapi/publishers", {"topic": "/scan"}))["publishers"] == ["/bus"]
        assert (await call("/rosapi/service_node", {"service": "/rosapi/nodes"}))[
            "node"
        ] == "/rosapi"
        assert (await call("/rosapi/get_ros_version"))["version"] == 2
        det = await call(
            "/rosapi/service_response_details", {"type": "robotrial_msgs/srv/PlanTask"}
        )
        assert det["typedefs"][0]["fieldnames"] == [
            "success",
            "message",
            "goal_joints",
            "trajectory",
            "planning_time",
            "error_code",
            "object_held",
        ]
        marker = await call("/rosapi/message_details", {"type": "visualization_msgs/Marker"})
        top = marker["typedefs"][0]
        assert top["constnames"][:2] == ["ARROW", "CUBE"] and "texture" not in top["fieldnames"]
        details = await call("/rosapi/node_details", {"node": c.session.name})
        assert details == {"subscribing": [], "publishing": [], "services": []}
        await c.send(
            {
                "op": "call_service",
                "id": "u",
                "service": "/rosapi/message_details",
                "args": {"type": "no/Such"},
            }
        )
        resp = await c.recv_op("service_response")
        assert resp["result"] is False and "not known" in resp["values"]

    run(main)


def test_a_session_whose_sends_fail_ends_and_frees_its_subscriptions() -> None:
    async def main() -> None:
        bus = Bus()
        server = RosbridgeServer(bus)

        async def broken_send(frame: str | bytes) -> None:
            raise ConnectionResetError("the peer went away")

        session = server.open_session(broken_send)
        await session.receive(
            json.dumps({"op": "subscribe", "topic": "/n", "type": "std_msgs/Int32"})
        )
        bus.publish("/n", {"data": 1}, "std_msgs/msg/Int32")
        await asyncio.wait_for(session.ended.wait(), 2.0)
        assert session.closed
        assert session not in server.sessions
        assert session.subscriptions == {}

    run(main)
