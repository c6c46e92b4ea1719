"""Hypothesis throws random and half-valid operations at sessions: nothing may crash,
every failure must be a clean status or failed response, and closing the clients must
leave nothing behind on the bus."""

from __future__ import annotations

import asyncio
import json
import random
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robotrial.msgs.std_srvs import SetBool
from robotrial.ros.bus import Bus
from robotrial.ros.rosbridge import Limits, RosbridgeServer
from robotrial.ros.rosbridge.protocol import COMPRESSIONS

OPS = [
    "advertise", "unadvertise", "publish", "subscribe", "unsubscribe", "call_service",
    "advertise_service", "unadvertise_service", "service_response", "fragment", "png",
    "set_level", "auth", "bogus",
]  # fmt: skip
NAMES = ["/chatter", "/joint_states", "/tf_static", "chatter", "/echo", "/rosapi/topics",
         "/rosapi/message_details", "/offered", "", "bad name", "/x//y"]  # fmt: skip
TYPES = ["std_msgs/String", "std_msgs/msg/String", "sensor_msgs/msg/JointState",
         "tf2_msgs/TFMessage", "std_srvs/srv/SetBool", "x/Y", "", "nope"]  # fmt: skip

SCALARS = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**70), 2**70),
    st.floats(),
    st.text(max_size=8),
)
values = (
    SCALARS
    | st.lists(SCALARS, max_size=3)
    | st.dictionaries(st.text(max_size=6), SCALARS, max_size=3)
)
PLAUSIBLE = {
    "id": st.sampled_from(["a", "b", 1, 2]),
    "topic": st.sampled_from(NAMES),
    "service": st.sampled_from(NAMES),
    "type": st.sampled_from(TYPES),
    "msg": st.sampled_from([{}, {"data": "x"}, {"name": ["j"], "position": [1.0]}, {"data": 3}]),
    "args": st.sampled_from([{}, {"data": True}, {"type": "std_msgs/String"}, {"topic": "/x"}]),
    "values": st.sampled_from([{}, {"success": True}, "failed", {"sum": 1}]),
    "result": st.booleans(),
    "throttle_rate": st.integers(-5, 30),
    "queue_length": st.integers(-1, 3),
    "fragment_size": st.integers(-1, 40),
    "compression": st.sampled_from([*COMPRESSIONS, "zip"]),
    "latch": st.booleans(),
    "level": st.sampled_from(["info", "warning", "error", "none", "x"]),
    "data": st.text(max_size=20),
    "num": st.integers(-1, 4),
    "total": st.integers(-1, 4),
    "timeout": st.floats(-1, 0.05),
}
ops = st.builds(
    lambda name, fields: {"op": name, **fields},
    st.sampled_from(OPS) | values,
    st.dictionaries(
        st.sampled_from(sorted(PLAUSIBLE)),
        st.one_of(*PLAUSIBLE.values()) | values,
        max_size=5,
    ),
)
frames = st.one_of(
    ops.map(json.dumps),
    ops.map(lambda op: json.dumps(op).encode()),
    st.binary(max_size=30),
    st.text(max_size=30),
)


def random_value(r: random.Random, depth: int = 0) -> Any:
    kind = r.randrange(8 if depth < 2 else 6)
    if kind == 0:
        return None
    if kind == 1:
        return r.random() < 0.5
    if kind == 2:
        return r.choice([0, 1, -1, 255, 256, 2**31, -(2**63) - 1, 2**64, r.randint(-100, 100)])
    if kind == 3:
        return r.choice([0.5, -1e308, float("nan"), float("inf"), r.uniform(-10, 10)])
    if kind in (4, 5):
        return "".join(r.choice('ab/_ é"{}[]0') for _ in range(r.randrange(12)))
    if kind == 6:
        return [random_value(r, depth + 1) for _ in range(r.randrange(4))]
    return {
        random_value(r, 2) if r.random() < 0.2 else r.choice(list(PLAUSIBLE)): random_value(
            r, depth + 1
        )
        for _ in range(r.randrange(4))
    }


def random_op(r: random.Random) -> Any:
    op: dict[Any, Any] = {"op": r.choice(OPS) if r.random() < 0.95 else random_value(r)}
    for key in r.sample(sorted(PLAUSIBLE), r.randrange(7)):
        op[key] = PLAUSIBLE_RANDOM[key](r) if r.random() < 0.7 else random_value(r)
    return op


PLAUSIBLE_RANDOM = {
    "id": lambda r: r.choice(["a", "b", 1, 2]),
    "topic": lambda r: r.choice(NAMES),
    "service": lambda r: r.choice(NAMES),
    "type": lambda r: r.choice(TYPES),
    "msg": lambda r: r.choice([{}, {"data": "x"}, {"name": ["j"], "position": [1.0]}, {"data": 3}]),
    "args": lambda r: r.choice([{}, {"data": True}, {"type": "std_msgs/String"}, {"topic": "/x"}]),
    "values": lambda r: r.choice([{}, {"success": True}, "failed", {"sum": 1}]),
    "result": lambda r: r.random() < 0.5,
    "throttle_rate": lambda r: r.randint(-5, 30),
    "queue_length": lambda r: r.randint(-1, 3),
    "fragment_size": lambda r: r.randint(-1, 40),
    "compression": lambda r: r.choice([*COMPRESSIONS, "zip"]),
    "latch": lambda r: r.random() < 0.5,
    "level": lambda r: r.choice(["info", "warning", "error", "none", "x"]),
    "data": lambda r: r.choice(["", "abc", '{"op":"publish"}', "iVBORw0KGgo="]),
    "num": lambda r: r.randint(-1, 4),
    "total": lambda r: r.randint(-1, 4),
    "timeout": lambda r: r.choice([-1, 0, 0.01, 0.05]),
}


def random_frame(r: random.Random) -> str | bytes:
    text = json.dumps(random_op(r))
    roll = r.random()
    if roll < 0.8:
        return text
    if roll < 0.88:
        return text.encode()
    if roll < 0.94:
        return text[: r.randrange(len(text))]
    return bytes(r.randrange(256) for _ in range(r.randrange(30)))


COUNT = {"frames": 0}


def _decode(frame: str | bytes) -> Any:
    from robotrial.msgs import cbor

    return json.loads(frame) if isinstance(frame, str) else cbor.loads(frame)


async def _episode(batch: list[tuple[int, str | bytes]]) -> None:
    bus = Bus()
    bus.advertise("/joint_states", "sensor_msgs/msg/JointState")
    bus.advertise_service(
        "/echo", SetBool, lambda r: SetBool.Response(success=r.data), threaded=False
    )
    server = RosbridgeServer(bus, limits=Limits(service_timeout=0.05))
    fixed_services, fixed_topics, fixed_nodes = bus.services(), bus.topics(), bus.nodes()
    inboxes: list[list] = [[], []]

    def sender(box: list):
        async def send(frame: str | bytes) -> None:
            box.append(_decode(frame))

        return send

    sessions = [server.open_session(sender(inboxes[i])) for i in range(2)]
    for who, frame in batch:
        await sessions[who].receive(frame)
        COUNT["frames"] += 1
    bus.publish("/joint_states", {"name": ["j"], "position": [1.0]})
    for _ in range(5):
        await asyncio.sleep(0)
    for s in sessions:
        await s.close()
    await asyncio.sleep(0)

    for box in inboxes:
        for out in box:
            text = json.dumps(out, default=str)
            assert "internal error" not in text, text
    assert server.sessions == set()
    assert bus.services() == fixed_services
    assert bus.topics() == fixed_topics
    assert bus.subscriber_count("/joint_states") == 0
    assert bus.nodes() == fixed_nodes
    server.close()


@settings(
    max_examples=150,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    database=None,
)
@given(st.lists(st.tuples(st.integers(0, 1), frames), min_size=10, max_size=30))
def test_fuzz_structured_operations(batch: list[tuple[int, str | bytes]]) -> None:
    asyncio.run(_episode(batch))


FRAMES_PER_EPISODE = 120


@settings(max_examples=90, deadline=None, database=None)
@given(st.integers(0, 2**32 - 1))
def _fuzz_bulk(seed: int) -> None:
    r = random.Random(seed)
    batch = [(r.randrange(2), random_frame(r)) for _ in range(FRAMES_PER_EPISODE)]
    asyncio.run(_episode(batch))


def test_fuzz_ten_thousand_messages() -> None:
    """The bulk run: hypothesis picks seeds for a fast generator of half-valid operations."""
    COUNT["frames"] = 0
    _fuzz_bulk()
    assert COUNT["frames"] >= 10_000
