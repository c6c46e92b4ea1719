"""Over a real WebSocket: many clients, garbage on the wire, clients that vanish."""

from __future__ import annotations

import asyncio
import json
import random
import threading
import time
from typing import Any

import websockets

from robotrial.msgs.sensor_msgs import JointState


def wait_for(cond, timeout: float = 5.0) -> None:
    deadline = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > deadline:
            raise AssertionError("condition not met in time")
        time.sleep(0.01)


async def recv_op(ws, op: str, timeout: float = 5.0) -> dict:
    while True:
        msg = json.loads(await asyncio.wait_for(ws.recv(), timeout))
        if msg.get("op") == op:
            return msg


def test_fifty_clients_receive_every_message(live) -> None:
    n_clients, n_msgs = 50, 100
    ready = threading.Event()

    async def client(i: int) -> list[float]:
        async with websockets.connect(f"{live.url}/rosbridge", max_size=None) as ws:
            await ws.send(
                json.dumps(
                    {
                        "op": "subscribe",
                        "id": f"c{i}",
                        "topic": "/bench",
                        "type": "sensor_msgs/JointState",
                        "queue_length": 100,
                    }
                )
            )
            await ws.send(
                json.dumps({"op": "call_service", "id": "sync", "service": "/rosapi/get_time"})
            )
            await recv_op(ws, "service_response")
            seen = []
            while len(seen) < n_msgs:
                msg = json.loads(await asyncio.wait_for(ws.recv(), 10))
                seen.append(msg["msg"]["position"][0])
            return seen

    async def main() -> list[list[float]]:
        tasks = [asyncio.create_task(client(i)) for i in range(n_clients)]
        while live.bus.subscriber_count("/bench") < n_clients:
            await asyncio.sleep(0.01)
        ready.set()
        return await asyncio.gather(*tasks)

    def publish() -> None:
        ready.wait(20)
        pub = live.bus.advertise("/bench", JointState)
        for k in range(n_msgs):
            pub.publish(JointState(name=["j"], position=[float(k)]))
            time.sleep(0.01)  # 100 Hz

    thread = threading.Thread(target=publish)
    thread.start()
    results = asyncio.run(main())
    thread.join()
    for seen in results:
        assert seen == [float(k) for k in range(n_msgs)]
    wait_for(lambda: live.bus.subscriber_count("/bench") == 0)


def test_garbage_on_the_wire_leaves_connection_and_server_up(live) -> None:
    rng = random.Random(5)

    async def main() -> None:
        async with websockets.connect(f"{live.url}/", max_size=None) as ws:
            for i in range(300):
                kind = i % 5
                if kind == 0:
                    await ws.send(bytes(rng.randrange(256) for _ in range(rng.randrange(1, 40))))
                elif kind == 1:
                    await ws.send("{" * rng.randrange(1, 5000))
                elif kind == 2:
                    await ws.send(
                        json.dumps({"op": rng.choice(["subscribe", "publish", "x"]), "topic": i})
                    )
                elif kind == 3:
                    await ws.send(
                        json.dumps(
                            {"op": "publish", "topic": "/joint_states", "msg": {"position": "x"}}
                        )
                    )
                else:
                    await ws.send(json.dumps([i, None, {"op": "subscribe"}]))
            await ws.send(
                json.dumps({"op": "call_service", "id": "alive", "service": "/rosapi/topics"})
            )
            resp = await recv_op(ws, "service_response", 10)
            assert resp["id"] == "alive" and resp["result"] is True
            # a message over the protocol limit (16 MiB) gets a status, not a disconnect
            await ws.send(
                json.dumps(
                    {
                        "op": "publish",
                        "id": "huge",
                        "topic": "/x",
                        "msg": {"data": "x" * (17 * 2**20)},
                    }
                )
            )
            status = await recv_op(ws, "status", 20)
            assert status["level"] == "error" and "larger than the limit" in status["msg"]
            await ws.send(
                json.dumps({"op": "call_service", "id": "still", "service": "/rosapi/nodes"})
            )
            assert (await recv_op(ws, "service_response", 10))["result"] is True

    asyncio.run(main())


def test_clients_vanishing_mid_call_are_cleaned_up(live) -> None:
    release = threading.Event()
    answered: list[Any] = []

    def slow(req: Any) -> Any:
        release.wait(10)
        answered.append(req)
        return {"success": True}

    live.bus.advertise_service("/slow", "std_srvs/srv/Trigger", slow)

    async def provider_then_vanish() -> None:
        ws = await websockets.connect(f"{live.url}/rosbridge")
        await ws.send(
            json.dumps({"op": "advertise_service", "service": "/ghost", "type": "std_srvs/Trigger"})
        )
        await ws.send(
            json.dumps(
                {"op": "subscribe", "topic": "/joint_states", "type": "sensor_msgs/JointState"}
            )
        )
        await ws.send(json.dumps({"op": "call_service", "id": "w", "service": "/slow"}))
        await asyncio.sleep(0.2)
        ws.transport.abort()  # no close handshake: the client just disappears

    async def caller_of_ghost() -> dict:
        async with websockets.connect(f"{live.url}/rosbridge") as ws:
            while "/ghost" not in live.bus.services():
                await asyncio.sleep(0.01)
            await ws.send(json.dumps({"op": "call_service", "id": "g", "service": "/ghost"}))
            return await recv_op(ws, "service_response", 10)

    async def main() -> dict:
        caller = asyncio.create_task(caller_of_ghost())
        await provider_then_vanish()
        return await caller

    answer = asyncio.run(main())
    assert answer["result"] is False
    assert "disconnected" in answer["values"] or "not offered" in answer["values"]
    release.set()
    wait_for(lambda: "/ghost" not in live.bus.services())
    wait_for(lambda: not [n for n in live.bus.nodes() if n.startswith("/rosbridge_websocket")])
    assert live.bus.subscriber_count("/joint_states") == 0
    wait_for(lambda: answered)  # the slow handler finished; its answer went nowhere, quietly


def test_untyped_subscribe_to_an_unknown_topic_is_an_error(live) -> None:
    """As rosbridge_suite answers: the type cannot be inferred, nothing is subscribed."""

    async def main() -> dict:
        async with websockets.connect(f"{live.url}/rosbridge") as ws:
            await ws.send(json.dumps({"op": "subscribe", "id": "s1", "topic": "/nobody"}))
            return await recv_op(ws, "status")

    status = asyncio.run(main())
    assert status["level"] == "error" and status["id"] == "s1"
    assert "cannot infer the type of /nobody" in status["msg"]
    assert live.bus.subscriber_count("/nobody") == 0
