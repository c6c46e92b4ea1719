"""The live platform view: `robotrial serve` with the mobile manipulator in room A runs
the simulator, SLAM and navigation on its bus; the page follows it over rosbridge. It
receives scans and draws them, keyboard driving moves the robot (its pose from /tf
changes), a click on the floor sends a navigation goal and the plan comes back, and
/map arrives as a texture."""

from __future__ import annotations

import io
import math
import time
from pathlib import Path

import httpx
import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import Page, sync_playwright

pytestmark = [pytest.mark.browser, pytest.mark.timeout(120)]


@pytest.fixture
def server(serve) -> str:
    """`robotrial serve --robot mobile_manipulator --world room_a`."""
    return serve("--robot", "mobile_manipulator", "--world", "room_a")


def wait_live(page: Page, condition: str, seconds: float, arg: object = None) -> dict:
    """Poll window.robotrial.state().live until `condition` (a JS function of the live
    state and `arg`) holds; fail with the last state seen."""
    deadline = time.monotonic() + seconds
    while True:
        live = page.evaluate("window.robotrial.state().live")
        if page.evaluate(f"([l, arg]) => ({condition})(l, arg)", [live, arg]):
            return live
        assert time.monotonic() < deadline, f"{condition} not met in {seconds} s: {live}"
        page.wait_for_timeout(250)


def test_live_view_scan_driving_goal_and_map(
    server: str, chromium: str, chromium_args: list[str], artifacts: Path
) -> None:
    live = httpx.get(server + "api/config").json()["live"]
    assert live["robot"] == "mobile_manipulator" and live["world"] == "room_a"
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=chromium_args)
        page = browser.new_page(viewport={"width": 1000, "height": 700})
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(server)
        page.wait_for_function(
            "() => { const s = window.robotrial && window.robotrial.state();"
            " return s && (s.error || (s.ready && s.live.active)); }",
            timeout=30_000,
        )
        assert page.evaluate("window.robotrial.state().error") is None
        assert page.locator("#live-view").is_visible()

        start = wait_live(page, "(l) => l.scans > 0 && l.scanPoints > 0 && l.pose", 30)
        # Spawned at (1, 1) in room A facing +x; odometry starts there.
        assert math.dist(start["pose"][:2], live["origin"]["xyz"][:2]) < 0.1, start
        page.screenshot(path=artifacts / "web_live_scan.png")

        # Drive forward with the arrow key (the page repeats /cmd_vel while it is held).
        page.locator("#view canvas").click(position={"x": 5, "y": 5})
        page.keyboard.down("ArrowUp")
        wait_live(
            page, "(l, [x, y]) => Math.hypot(l.pose[0] - x, l.pose[1] - y) > 0.3", 45, start["pose"]
        )
        assert page.evaluate("window.robotrial.state().live.drive[0]") > 0
        page.keyboard.up("ArrowUp")
        page.wait_for_function("window.robotrial.state().live.drive[0] === 0")
        moved = page.evaluate("window.robotrial.state().live.pose")
        assert moved[0] > start["pose"][0] + 0.3, (start["pose"], moved)
        assert abs(moved[1] - start["pose"][1]) < 0.2, (start["pose"], moved)

        # A navigation goal from a click on the floor.
        page.click("#live-goal")
        view = page.locator("#view canvas").bounding_box()
        assert view is not None
        # The camera looks at the robot from the room's side: low in the view is the
        # floor between them, a metre or more from the robot.
        page.mouse.click(view["x"] + view["width"] * 0.5, view["y"] + view["height"] * 0.95)
        goal = page.evaluate("window.robotrial.state().live.goal")
        assert goal is not None and all(map(math.isfinite, goal)), goal
        assert math.dist(goal, moved[:2]) > 0.8, (goal, moved)
        # The navigation node plans to it: /plan comes back and is drawn.
        assert wait_live(page, "(l) => l.plan > 1", 30)["plan"] > 1

        # SLAM publishes the map within its update interval.
        grid = wait_live(page, "(l) => l.map", 30)["map"]
        assert grid["width"] > 0 and grid["height"] > 0 and grid["resolution"] > 0
        page.wait_for_timeout(300)
        page.screenshot(path=artifacts / "web_live_map.png")
        canvas = page.locator("#view canvas").screenshot()
        pixels = np.asarray(Image.open(io.BytesIO(canvas)).convert("RGB"), dtype=int)
        red = (pixels[..., 0] > 180) & (pixels[..., 1] < 110) & (pixels[..., 2] < 110)
        assert red.sum() > 20, "the scan's points are drawn"
        assert not errors, errors
        browser.close()


def test_navigate_to_pose_through_the_web_apps_rosbridge(server: str) -> None:
    """A ROS 2 client drives the live platform with Nav2's action, on the page's rosbridge."""
    import threading

    import roslibpy

    ros = roslibpy.Ros(host=server.replace("http://", "ws://") + "rosbridge")
    ros.run(timeout=20)
    try:
        servers = roslibpy.Service(
            ros, "/rosapi/action_servers", "rosapi_msgs/srv/GetActionServers"
        )
        deadline = time.monotonic() + 30  # the live platform starts beside the server
        while "/navigate_to_pose" not in servers.call(roslibpy.ServiceRequest())["action_servers"]:
            assert time.monotonic() < deadline, "the live platform never offered the action"
            time.sleep(0.5)
        client = roslibpy.ActionClient(ros, "/navigate_to_pose", "nav2_msgs/action/NavigateToPose")
        done, feedback, answer = threading.Event(), [], {}
        goal = {"pose": {"header": {"frame_id": "map"}, "pose": {"position": {"x": 0.6}}}}
        client.send_goal(
            roslibpy.Goal(goal),
            lambda r: (answer.update(r), done.set()),
            feedback.append,
            lambda e: (answer.update(error=e), done.set()),
        )
        assert done.wait(60), "no action_result in time"
    finally:
        ros.close()
    assert answer.get("status") == roslibpy.core.GoalStatus.SUCCEEDED, answer
    assert feedback and feedback[-1]["distance_remaining"] < feedback[0]["distance_remaining"]
