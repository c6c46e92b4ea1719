"""One clock: while a simulator runs, what clients read as the time is simulated time, the
time in the message headers. roslibpy's get_time(), rosbridge's "now", /clock
(rosgraph_msgs/Clock) over rosbridge, and the Foxglove server's time capability all agree
with the simulation, not the wall clock."""

from __future__ import annotations

import json
import time
from collections.abc import Iterator

import pytest
import roslibpy

from robotrial.ros.bus import Bus
from robotrial.ros.foxglove_bridge import FoxgloveBridge
from robotrial.ros.sim_node import SimNode
from robotrial.sim.simulation import SimOptions, Simulation

from .conftest import start_server, stop_server
from .test_foxglove import run_node

RUN_FOR = 1.5  # simulated s before the clients look


@pytest.fixture(scope="module")
def desk() -> Iterator[tuple[Bus, SimNode]]:
    """The desk arm simulated for RUN_FOR s, then paused: its clock stands still."""
    bus = Bus()
    with Simulation.create("desk", "desk_arm", options=SimOptions(cameras=False)) as sim:
        node = SimNode(bus, sim)
        node.run(RUN_FOR)
        yield bus, node
        node.destroy()


def test_rosapi_now_and_clock_follow_the_simulation(desk, port) -> None:
    bus, node = desk
    assert bus.now() == pytest.approx(RUN_FOR)
    server = start_server(bus, port)
    ros = roslibpy.Ros(host="127.0.0.1", port=port)
    ros.run(timeout=10)
    try:
        t = ros.get_time()
        assert t.secs + t.nsecs * 1e-9 == pytest.approx(RUN_FOR)
        stamps = []
        bus.subscribe("/stamped", stamps.append, "std_msgs/msg/Header")
        pub = roslibpy.Topic(ros, "/stamped", "std_msgs/msg/Header")
        pub.publish(roslibpy.Message({"stamp": "now", "frame_id": "desk"}))
        clocks: list = []
        clock = roslibpy.Topic(ros, "/clock", "rosgraph_msgs/msg/Clock")
        clock.subscribe(clocks.append)
        deadline = time.monotonic() + 10
        while bus.subscriber_count("/clock") == 0 or not stamps:
            assert time.monotonic() < deadline, "no /clock subscriber or no /stamped message"
            time.sleep(0.02)
        node.step()
        while not clocks:
            assert time.monotonic() < deadline, "no /clock message"
            time.sleep(0.02)
        assert stamps[0].stamp.to_sec() == pytest.approx(RUN_FOR)
        c = clocks[0]["clock"]
        assert c["sec"] + c["nanosec"] * 1e-9 == pytest.approx(RUN_FOR + node.sim.control_dt)
    finally:
        ros.close()
        stop_server(server)


def test_foxglove_offers_the_simulated_time(desk) -> None:
    bus, _ = desk
    bridge = FoxgloveBridge(bus, port=0)
    try:
        proc = run_node("time.mjs", bridge.url)
    finally:
        bridge.destroy()
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    assert "time" in result["capabilities"]
    assert {int(t) for t in result["times"]} == {round(bus.now() * 1e9)}
