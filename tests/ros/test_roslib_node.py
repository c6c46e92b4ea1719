"""roslib (roslibjs) 2.x in Node talks to the server: every common client path."""

from __future__ import annotations

import json
import shutil
import subprocess
import time
from pathlib import Path

import pytest

NODE_DIR = Path(__file__).parent / "node"


def test_roslib_node_client(live) -> None:
    node = shutil.which("node")
    if node is None or not (NODE_DIR / "node_modules" / "roslib").is_dir():
        pytest.fail("node and tests/ros/node/node_modules are needed: run `make setup`")
    proc = subprocess.run(
        [node, "interop.mjs", f"{live.url}/rosbridge"],
        cwd=NODE_DIR,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 0, proc.stderr
    r = json.loads(proc.stdout)
    map_w, map_h = live.map_size

    assert "/joint_states" in r["topics"]["topics"]
    types = dict(zip(r["topics"]["topics"], r["topics"]["types"], strict=True))
    assert types["/map"] == "nav_msgs/msg/OccupancyGrid"
    assert "/robotrial/plan_task" in r["services"]

    assert r["plan"]["success"] is True
    assert r["plan"]["goal_joints"] == pytest.approx([1.1, 1.2])
    assert r["plan"]["trajectory"]["joint_names"] == ["j1", "j2"]
    assert "not offered" in r["missing"]

    for m in r["joint_states_json"] + r["joint_states_cbor"]:
        assert m["name"] == ["j1", "j2"]
        assert m["position"][1] == -0.25
    assert all(m["typed"] for m in r["joint_states_cbor"])

    assert r["map_png"] == {"width": map_w, "height": map_h, "cells": map_w * map_h}
    assert r["map_fragments"] == {"cells": map_w * map_h, "width": map_w}

    assert r["offered"] == {"sum": 42}
    decoded = r["decoded"]
    assert set(decoded) >= {"header", "name", "position", "velocity", "effort"}
    assert r["param"] == "tiny_arm"
    assert "/robot_name" in r["params"]
    assert r["status"]["level"] == "error" and "topic" in r["status"]["msg"]
    assert any(n.startswith("/rosbridge_websocket") for n in r["after_error"])

    deadline = time.monotonic() + 5
    while len(live.cmd_vel) < 3 and time.monotonic() < deadline:
        time.sleep(0.02)
    assert len(live.cmd_vel) == 3
    assert live.cmd_vel[0].linear.x == 0.5 and live.cmd_vel[0].angular.z == 0.25
    # the client has gone: nothing of it is left on the bus
    deadline = time.monotonic() + 5
    while live.bus.service("/node/add_two_ints") and time.monotonic() < deadline:
        time.sleep(0.02)
    assert live.bus.service("/node/add_two_ints") is None
