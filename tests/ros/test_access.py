"""Who may drive the robot: pages from other sites are refused at the WebSocket handshake
and on uploads; clients without an Origin (roslibpy, Node) and the server's own page are
let in; `--allow-origin` adds sites; with a token, nothing but `auth` is answered until
the token is given. Raw WebSockets, roslibpy and HTTP, against real servers."""

from __future__ import annotations

import asyncio
import json
import time

import pytest
import roslibpy
import websockets
from fastapi.testclient import TestClient
from websockets.exceptions import InvalidStatus

from robotrial.app.server import create_app
from robotrial.cli import main
from robotrial.ros.bus import Bus
from robotrial.ros.rosbridge.access import Access
from tests.conftest import LOCAL

from .conftest import start_server, stop_server

TWIST = {"linear": {"x": 0.5, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}
TOKEN = "correct-horse-battery"


@pytest.fixture
def served(port):
    """Start a standalone rosbridge server with an Access rule; a /cmd_vel recorder."""
    started = []

    def start(access: Access | None = None) -> tuple[str, list]:
        bus = Bus()
        got: list = []
        bus.subscribe("/cmd_vel", got.append, "geometry_msgs/msg/Twist")
        started.append(start_server(bus, port, access))
        return f"ws://127.0.0.1:{port}", got

    yield start
    for server in started:
        stop_server(server)


async def _drive(url: str, first: list[dict] = (), **kwargs) -> list[dict]:
    """Connect, send `first`, advertise and publish one /cmd_vel, and return the
    status messages the server sent back."""
    async with websockets.connect(url, **kwargs) as ws:
        for op in first:
            await ws.send(json.dumps(op))
        await ws.send(
            json.dumps({"op": "advertise", "topic": "/cmd_vel", "type": "geometry_msgs/msg/Twist"})
        )
        await ws.send(json.dumps({"op": "publish", "topic": "/cmd_vel", "msg": TWIST}))
        await ws.send(json.dumps({"op": "call_service", "id": "t", "service": "/rosapi/get_time"}))
        seen = []
        try:
            while True:
                msg = json.loads(await asyncio.wait_for(ws.recv(), 2))
                seen.append(msg)
                if msg.get("op") == "service_response":
                    break
        except (TimeoutError, websockets.ConnectionClosed):
            pass
        return seen


def _wait(cond, timeout: float = 3.0) -> bool:
    deadline = time.monotonic() + timeout
    while not cond() and time.monotonic() < deadline:
        time.sleep(0.02)
    return cond()


def test_a_page_from_another_site_cannot_connect(served, port):
    url, got = served()
    with pytest.raises(InvalidStatus) as err:
        asyncio.run(_drive(f"{url}/rosbridge", origin="http://evil.example.com"))
    assert err.value.response.status_code == 403
    # DNS rebinding: another site's name pointed at this machine is not the page's own
    with pytest.raises(InvalidStatus):
        asyncio.run(
            _drive(
                f"{url}/rosbridge",
                origin=f"http://evil.example.com:{port}",
                additional_headers={"Host": f"evil.example.com:{port}"},
            )
        )
    time.sleep(0.3)
    assert got == []


def test_own_page_and_clients_without_origin_can_drive(served, port):
    url, got = served()
    asyncio.run(_drive(f"{url}/rosbridge", origin=f"http://127.0.0.1:{port}"))
    asyncio.run(_drive(f"{url}/rosbridge", origin=f"http://localhost:{port}"))
    assert _wait(lambda: len(got) == 2)
    ros = roslibpy.Ros("127.0.0.1", port)
    ros.run(timeout=5)
    try:
        topic = roslibpy.Topic(ros, "/cmd_vel", "geometry_msgs/msg/Twist")
        topic.publish(roslibpy.Message(TWIST))
        assert _wait(lambda: len(got) == 3)
    finally:
        ros.close()


def test_allow_origin_adds_a_site(served):
    url, got = served(Access.create(allow_origins=["https://studio.example.org/"]))
    asyncio.run(_drive(url, origin="https://studio.example.org"))
    assert _wait(lambda: len(got) == 1)
    with pytest.raises(InvalidStatus):
        asyncio.run(_drive(url, origin="https://other.example.org"))


def test_with_a_token_nothing_but_auth_is_answered(served):
    url, got = served(Access.create(token=TOKEN))
    seen = asyncio.run(_drive(url))
    assert any("not authenticated" in m.get("msg", "") for m in seen)
    assert not any(m.get("op") == "service_response" for m in seen)
    seen = asyncio.run(_drive(url, [{"op": "auth", "mac": "wrong-token-here"}]))
    assert any("wrong token" in m.get("msg", "") for m in seen)
    time.sleep(0.3)
    assert got == []
    seen = asyncio.run(_drive(url, [{"op": "auth", "mac": TOKEN}]))
    assert any(m.get("op") == "service_response" for m in seen)
    asyncio.run(_drive(f"{url}/rosbridge?token={TOKEN}"))
    assert _wait(lambda: len(got) == 2)


def test_roslibpy_authenticates_with_the_token(served, port):
    _, got = served(Access.create(token=TOKEN))
    ros = roslibpy.Ros("127.0.0.1", port)
    ros.authenticate(TOKEN, "", "", "", 0, "", 0)
    ros.run(timeout=5)
    try:
        # roslibpy sends `auth` from its ready handler, which may run after the first
        # publish; a teleop client publishes at a rate, so later messages get through
        topic = roslibpy.Topic(ros, "/cmd_vel", "geometry_msgs/msg/Twist")
        assert _wait(lambda: topic.publish(roslibpy.Message(TWIST)) or bool(got))
        assert got[0].linear.x == 0.5
    finally:
        ros.close()


def test_uploads_follow_the_same_rule(tmp_path):
    urdf = b'<robot name="cube"><link name="base"/></robot>'
    with TestClient(create_app(warm=False, uploads_dir=tmp_path / "a"), base_url=LOCAL) as client:
        r = client.post(
            "/api/robots/upload",
            files={"file": ("cube.urdf", urdf)},
            headers={"Origin": "http://evil.example.com"},
        )
        assert r.status_code == 403 and "--allow-origin http://evil.example.com" in r.text
        r = client.post("/api/robots/upload", files={"file": ("cube.urdf", urdf)})
        assert r.status_code == 201
    app = create_app(warm=False, uploads_dir=tmp_path / "b", access=Access.create(token=TOKEN))
    with TestClient(app, base_url=LOCAL) as client:
        r = client.post("/api/robots/upload", files={"file": ("cube.urdf", urdf)})
        assert r.status_code == 401
        auth = {"Authorization": f"Bearer {TOKEN}"}
        r = client.post("/api/robots/upload", files={"file": ("cube.urdf", urdf)}, headers=auth)
        assert r.status_code == 201


def test_bad_token_options_are_named(tmp_path, capsys):
    def err() -> str:
        return " ".join(capsys.readouterr().err.split())

    empty = tmp_path / "token.txt"
    empty.write_text("")
    assert main(["rosbridge", "--token-file", str(empty)]) == 2
    assert "token.txt: the file is empty" in err()
    assert main(["serve", "--token", "short"]) == 2
    assert "at least 8 characters" in err()
    assert main(["rosbridge", "--token", TOKEN, "--token-file", str(empty)]) == 2
    assert "not both" in err()
