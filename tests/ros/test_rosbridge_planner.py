"""`robotrial rosbridge --robot NAME --world NAME` offers /robotrial/plan_task: a
roslibpy client plans the g2rViewer desk task against the standalone server."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest
import roslibpy

from robotrial.benchmarks.planning import DESK_REQUEST
from robotrial.cli import main

from ..conftest import free_port

pytestmark = pytest.mark.timeout(120)

# the page's desk request, with the all-zero orientation that also means position only
REQUEST = {
    **DESK_REQUEST,
    "ee_goal": {
        **DESK_REQUEST["ee_goal"],
        "orientation": {"x": 0, "y": 0, "z": 0, "w": 0},
    },
}


def test_standalone_rosbridge_plans_for_its_robot(tmp_path):
    port = free_port()
    command = [Path(sys.executable).with_name("robotrial"), "rosbridge", "--port", str(port)]
    log = tmp_path / "rosbridge.log"
    with log.open("w") as errors:
        proc = subprocess.Popen(
            [*command, "--robot", "desk_arm", "--world", "desk"],
            stdout=subprocess.PIPE,
            stderr=errors,
            text=True,
        )
    ros = roslibpy.Ros("127.0.0.1", port)
    try:
        assert "rosbridge v2 on" in proc.stdout.readline(), log.read_text()
        deadline = time.monotonic() + 30
        while not ros.is_connected:
            try:
                ros.run(timeout=2)
            except Exception:
                assert time.monotonic() < deadline and proc.poll() is None, log.read_text()
        service = roslibpy.Service(ros, "/robotrial/plan_task", "robotrial_msgs/srv/PlanTask")
        answer = service.call(roslibpy.ServiceRequest(REQUEST), timeout=60)
        assert answer["success"], answer["message"]
        assert len(answer["goal_joints"]) == 6 and answer["trajectory"]["points"]
        # a goal sent without an orientation is a position-only goal
        position_only = {**REQUEST, "ee_goal": {"position": REQUEST["ee_goal"]["position"]}}
        answer = service.call(roslibpy.ServiceRequest(position_only), timeout=60)
        assert answer["success"], answer["message"]
    finally:
        ros.close()
        proc.terminate()
        proc.wait(10)


def test_world_without_robot_is_refused(capsys):
    assert main(["rosbridge", "--world", "desk"]) == 2
    assert "--world and --tool need --robot" in " ".join(capsys.readouterr().err.split())
    assert main(["rosbridge", "--robot", "r2d2"]) == 2
    assert "unknown robot 'r2d2'" in " ".join(capsys.readouterr().err.split())
