"""The server under a hostile load, with real sockets: clients that ask for compression do
not get it, a client that stops reading is told why and dropped, and the others, rosbridge
and HTTP alike, keep being served meanwhile."""

from __future__ import annotations

import asyncio
import base64
import json
import os
import socket
import struct
import threading
import time

import httpx
import numpy as np
import pytest
import websockets

from robotrial.app.server import create_app
from robotrial.msgs.sensor_msgs import PointCloud2, PointField
from robotrial.msgs.std_msgs import Header
from robotrial.ros.bus import Bus, Node
from robotrial.ros.rosbridge.protocol import Limits
from robotrial.ros.rosbridge.transport import uvicorn_config
from tests.ros.conftest import start_server, stop_server

POINTS = 30_000  # a VLP-16 sweep: about half a megabyte a message in JSON
STALL_S = 1.0


class CloudPublisher(Node):
    """Publishes a PointCloud2 of POINTS points on /points at 10 Hz."""

    def __init__(self, bus: Bus) -> None:
        super().__init__(bus, "/lidar")
        self.pub = self.create_publisher("/points", PointCloud2)
        fields = [
            PointField(name=n, offset=4 * i, datatype=7, count=1) for i, n in enumerate("xyz")
        ]
        data = np.random.default_rng(0).random((POINTS, 3), dtype=np.float32).tobytes()
        self.cloud = dict(height=1, width=POINTS, fields=fields, point_step=12)
        self.data = data
        self.create_timer(0.1, self.tick)

    def tick(self) -> None:
        self.pub.publish(
            PointCloud2(
                header=Header(frame_id="lidar"),
                row_step=len(self.data),
                data=self.data,
                **self.cloud,
            )
        )


@pytest.fixture
def loaded(port: int):
    """The web app with rosbridge (stall limit STALL_S) and a 10 Hz point cloud."""
    import uvicorn

    bus = Bus()
    publisher = CloudPublisher(bus)
    app = create_app(bus=bus, warm=False)
    app.state.rosbridge.limits = Limits(stall_timeout=STALL_S)
    server = uvicorn.Server(uvicorn_config(app, "127.0.0.1", port))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    while not server.started:
        assert thread.is_alive()
        time.sleep(0.02)
    server._test_thread = thread  # type: ignore[attr-defined]
    yield port
    stop_server(server)
    publisher.destroy()


def _stalled(port: int) -> tuple[socket.socket, str]:
    """A WebSocket that offers permessage-deflate, subscribes to /points and never reads;
    returns the socket and the server's handshake answer."""
    sock = socket.create_connection(("127.0.0.1", port), timeout=10)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall(
        (
            f"GET /rosbridge HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\n"
            f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n"
            "Sec-WebSocket-Extensions: permessage-deflate\r\n\r\n"
        ).encode()
    )
    head = b""
    while b"\r\n\r\n" not in head:
        head += sock.recv(1)
    payload = json.dumps({"op": "subscribe", "topic": "/points"}).encode()
    mask = os.urandom(4)
    frame = bytes([0x81, 0x80 | 126]) + struct.pack("!H", len(payload)) + mask
    sock.sendall(frame + bytes(b ^ mask[i % 4] for i, b in enumerate(payload)))
    return sock, head.decode()


def _closed_by_server(sock: socket.socket, within: float) -> bool:
    """Read everything the server sent; True once it has closed the connection."""
    sock.settimeout(0.5)
    deadline = time.monotonic() + within
    while time.monotonic() < deadline:
        try:
            if not sock.recv(1 << 20):
                return True
        except TimeoutError:
            continue
        except OSError:
            return True
    return False


def test_compression_is_not_negotiated(loaded: int) -> None:
    async def handshake() -> str | None:
        async with websockets.connect(
            f"ws://127.0.0.1:{loaded}/rosbridge", compression="deflate"
        ) as ws:
            return ws.response.headers.get("Sec-WebSocket-Extensions")

    assert asyncio.run(handshake()) is None


def test_a_client_that_stops_reading_is_dropped_and_the_rest_are_served(loaded: int) -> None:
    stalled, handshake = _stalled(loaded)
    assert "permessage-deflate" not in handshake.lower()

    async def reader() -> int:
        frames = 0
        async with websockets.connect(f"ws://127.0.0.1:{loaded}/rosbridge", max_size=None) as ws:
            await ws.send(json.dumps({"op": "subscribe", "topic": "/points"}))
            end = time.monotonic() + 6 * STALL_S
            while time.monotonic() < end:
                msg = json.loads(await asyncio.wait_for(ws.recv(), 10))
                frames += msg["op"] == "publish"
        return frames

    answered: list[int] = []

    def probe() -> None:
        with httpx.Client(timeout=10) as http:
            for _ in range(10):
                answered.append(http.get(f"http://127.0.0.1:{loaded}/api/config").status_code)
                time.sleep(0.3)

    prober = threading.Thread(target=probe)
    prober.start()
    frames = asyncio.run(reader())
    prober.join()
    assert frames >= 10  # the reading client got the cloud all along
    assert answered == [200] * 10
    # the stalled client's frames waited past the limit: its connection was closed
    assert _closed_by_server(stalled, within=10 * STALL_S)
    stalled.close()


def test_a_wrong_token_closes_the_connection_at_once(port: int) -> None:
    """After a wrong `auth` nothing is read, not even the right token sent next."""
    from robotrial.ros.rosbridge.access import Access

    bus = Bus()
    got: list = []
    bus.subscribe("/cmd_vel", got.append, "geometry_msgs/msg/Twist")
    token = "correct-horse-battery"
    server = start_server(bus, port, Access.create(token=token))

    async def guess() -> tuple[list[dict], int | None]:
        seen = []
        async with websockets.connect(f"ws://127.0.0.1:{port}") as ws:
            for mac in ["wrong-guess-1", token]:
                await ws.send(json.dumps({"op": "auth", "mac": mac}))
            await ws.send(
                json.dumps(
                    {"op": "advertise", "topic": "/cmd_vel", "type": "geometry_msgs/msg/Twist"}
                )
            )
            await ws.send(json.dumps({"op": "publish", "topic": "/cmd_vel", "msg": {}}))
            try:
                while True:
                    seen.append(json.loads(await asyncio.wait_for(ws.recv(), 5)))
            except websockets.ConnectionClosed as closed:
                return seen, closed.rcvd.code if closed.rcvd else None

    try:
        seen, code = asyncio.run(guess())
    finally:
        stop_server(server)
    assert [m.get("msg") for m in seen] == ["auth: wrong token; the connection is closed"]
    assert code == 1008
    assert got == []
