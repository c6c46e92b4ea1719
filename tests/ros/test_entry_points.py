"""The two ways to reach rosbridge: `robotrial rosbridge` and /rosbridge on the web app."""

from __future__ import annotations

import asyncio
import json
import socket
import subprocess
import sys
import time
from pathlib import Path

import uvicorn
import websockets

from robotrial.ros.bus import Bus
from robotrial.ros.rosbridge.transport import uvicorn_config


async def _call(url: str, service: str) -> dict:
    async with websockets.connect(url) as ws:
        await ws.send(json.dumps({"op": "call_service", "id": "1", "service": service}))
        while True:
            msg = json.loads(await asyncio.wait_for(ws.recv(), 10))
            if msg["op"] == "service_response":
                return msg


def _wait_port(port: int, timeout: float = 20) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            with socket.create_connection(("127.0.0.1", port), 0.2):
                return
        except OSError:
            time.sleep(0.05)
    raise AssertionError(f"nothing listens on {port}")


def test_robotrial_rosbridge_command(port) -> None:
    proc = subprocess.Popen(
        [
            str(Path(sys.executable).parent / "robotrial"),
            "rosbridge",
            "--port",
            str(port),
            "--ros-version",
            "1",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        try:
            _wait_port(port)
        except AssertionError:
            proc.terminate()
            raise AssertionError(
                f"robotrial rosbridge did not start: {proc.communicate()}"
            ) from None
        for path in ("/", "/rosbridge"):
            resp = asyncio.run(_call(f"ws://127.0.0.1:{port}{path}", "/rosapi/get_ros_version"))
            assert resp["values"] == {"version": 1, "distro": "noetic"}
    finally:
        proc.terminate()
        out, err = proc.communicate(timeout=10)
    assert f"ws://127.0.0.1:{port}/" in out
    assert proc.returncode == 128 + 15 and "Traceback" not in err, err  # SIGTERM: no trace


def test_rosbridge_route_on_the_web_app(port) -> None:
    from robotrial.app.server import create_app

    bus = Bus()
    bus.advertise_service(
        "/robotrial/plan_task", "robotrial_msgs/srv/PlanTask", lambda r: {"success": True}
    )
    server = uvicorn.Server(uvicorn_config(create_app(bus=bus, warm=False), "127.0.0.1", port))

    async def main() -> dict:
        serving = asyncio.create_task(server.serve())
        while not server.started:
            await asyncio.sleep(0.02)
        try:
            return await _call(f"ws://127.0.0.1:{port}/rosbridge", "/robotrial/plan_task")
        finally:
            server.should_exit = True
            await serving

    resp = asyncio.run(main())
    assert resp["result"] is True and resp["values"]["success"] is True
