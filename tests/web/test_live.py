"""The live platform view (the RViz role): `robotrial serve` with the mobile manipulator
in room A runs the simulator, SLAM and navigation on its bus; the page follows it over
rosbridge. One server and one page for the module: it draws the scan, the map as a
layer (free, occupied and unknown apart, and hidden by its toggle), the footprint;
keyboard driving moves the robot; a goal pressed on the floor and dragged gets its
heading, drawn as an arrow, planned (global and local plan drawn) and driven to while
the status line says what the navigator does; goals in a wall, off the map or under the
robot are answered in words at once; a pose estimate goes out on /initialpose; a ROS 2
client drives it with Nav2's action. Screenshots go to test-artifacts/."""

from __future__ import annotations

import io
import math
import re
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import Page

pytestmark = [pytest.mark.browser, pytest.mark.timeout(180)]

LIVE = """() => { const s = window.robotrial && window.robotrial.state();
    return s && (s.error || (s.ready && s.live.active)); }"""


@pytest.fixture(scope="module")
def server(serve) -> str:
    """`robotrial serve --robot mobile_manipulator --world room_a`, once for the module."""
    return serve("--robot", "mobile_manipulator", "--world", "room_a")


@pytest.fixture(scope="module")
def page(server: str, browser) -> Iterator[Page]:
    """The page, once the live platform streams its pose, map and footprint."""
    page = browser.new_page(viewport={"width": 1200, "height": 760})
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(server)
    page.wait_for_function(LIVE, timeout=60_000)
    assert page.evaluate("window.robotrial.state().error") is None
    wait_live(page, "(l) => l.pose && l.map && l.footprint === 4 && l.scanPoints > 0", 60)
    yield page
    assert not errors, errors
    page.close()


def wait_live(page: Page, condition: str, seconds: float, arg: object = None) -> dict:
    """Poll window.robotrial.state().live until `condition` (a JS function of the live
    state and `arg`) holds; fail with the last state seen."""
    deadline = time.monotonic() + seconds
    while True:
        live = page.evaluate("window.robotrial.state().live")
        if page.evaluate(f"([l, arg]) => ({condition})(l, arg)", [live, arg]):
            return live
        assert time.monotonic() < deadline, f"{condition} not met in {seconds} s: {live}"
        page.wait_for_timeout(200)


def floor(live: dict, east: float, north: float) -> tuple[float, float]:
    """Canvas pixel of the floor `east` m along +x and `north` m along +y of the robot
    (the view from above keeps the floor's scale the same everywhere)."""
    s = live["screen"]
    r, e, n = (np.array(s[k]) for k in ("robot", "east", "north"))
    return tuple(r + east * (e - r) + north * (n - r))


def press(page: Page, tool: str, at: tuple[float, float], drag_to=None) -> None:
    """Press `tool`'s button, then press on the canvas at `at`, drag, let go."""
    box = page.locator("#view canvas").bounding_box()
    page.click(tool)
    page.mouse.move(box["x"] + at[0], box["y"] + at[1])
    page.mouse.down()
    if drag_to is not None:
        page.mouse.move(box["x"] + drag_to[0], box["y"] + drag_to[1], steps=6)
    page.mouse.up()


def canvas_pixels(page: Page) -> np.ndarray:
    shot = page.locator("#view canvas").screenshot()
    return np.asarray(Image.open(io.BytesIO(shot)).convert("RGB"), dtype=int)


def test_scan_map_layer_footprint_and_keyboard_driving(
    server: str, page: Page, artifacts: Path
) -> None:
    live = httpx.get(server + "api/config").json()["live"]
    assert live["robot"] == "mobile_manipulator" and live["world"] == "room_a"
    start = page.evaluate("window.robotrial.state().live")
    # Spawned at (1, 1) in room A facing +x; odometry starts there.
    assert math.dist(start["pose"][:2], live["origin"]["xyz"][:2]) < 0.1, start
    assert page.locator("#live-view").is_visible() and page.locator("#live-hud").is_visible()
    assert start["statusLine"] == "Waiting for a goal."
    # SLAM's map: free, occupied and unknown cells all there, each drawn its own way.
    cells = start["mapCells"]
    assert min(cells.values()) > 500 and start["mapShown"], cells
    page.click("#live-top")
    page.wait_for_timeout(600)
    shown = canvas_pixels(page)
    page.screenshot(path=artifacts / "web_live_map.png")
    red = (shown[..., 0] > 180) & (shown[..., 1] < 110) & (shown[..., 2] < 110)
    assert red.sum() > 20, "the scan's points are drawn"
    blue = (shown[..., 2] > 150) & (shown[..., 0] < 80) & (shown[..., 1] < 120)
    assert blue.sum() > 20, "the footprint's outline is drawn"
    page.uncheck("#live-map")
    page.wait_for_timeout(400)
    hidden = canvas_pixels(page)
    assert not page.evaluate("window.robotrial.state().live.mapShown")
    changed = (np.abs(shown - hidden).sum(axis=2) > 40).mean()
    assert changed > 0.05, f"the map layer's toggle changed {changed:.1%} of the view"
    page.check("#live-map")

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
    assert moved[0] > start["pose"][0] + 0.3 and abs(moved[1] - start["pose"][1]) < 0.2


def test_a_goal_pressed_and_dragged_is_planned_driven_and_said(page: Page, artifacts: Path):
    page.click("#live-top")
    page.wait_for_timeout(600)
    live = page.evaluate("window.robotrial.state().live")
    x0, y0, _ = live["pose"]
    # 2.5 m ahead and 1.5 m to the left, dragged towards +y: the goal faces north
    press(page, "#live-goal", floor(live, 2.5, 1.5), floor(live, 2.5, 2.5))
    page.wait_for_timeout(300)  # the view redraws at most ten times a second
    magenta = canvas_pixels(page)
    sent = page.evaluate("window.robotrial.state().live.goal")
    assert math.dist(sent[:2], (x0 + 2.5, y0 + 1.5)) < 0.15, sent
    assert abs(sent[2] - math.pi / 2) < 0.2, "the drag set the goal's heading"
    arrow = (magenta[..., 0] > 150) & (magenta[..., 1] < 80) & (magenta[..., 2] > 150)
    assert arrow.sum() > 15, f"the goal's arrow is drawn ({arrow.sum()} pixels)"
    # a loaded machine may take longer to look at the page than the drive takes: the
    # page keeps the line it said on entering each state
    driving = wait_live(
        page, "(l) => l.statusHistory.includes('driving') && l.plan > 1 && l.localPlan > 1", 40
    )
    page.screenshot(path=artifacts / "web_live_driving.png")
    said = driving["statusLines"][driving["statusHistory"].index("driving")]
    assert "to go" in said and "so far" in said, said
    to_go = float(re.search(r"([0-9.]+) m to go", said).group(1))
    done = wait_live(page, "(l) => ['reached', 'failed'].includes(l.status.state)", 60)
    page.screenshot(path=artifacts / "web_live_reached.png")
    assert done["status"]["state"] == "reached", done["statusLine"]
    assert done["statusLine"].startswith("Reached the goal in")
    assert math.dist(done["pose"][:2], sent[:2]) < 0.3
    assert abs((done["pose"][2] - sent[2] + math.pi) % (2 * math.pi) - math.pi) < 0.3
    assert done["status"]["distance"] < to_go


@pytest.mark.parametrize(
    ("where", "answer"),
    [
        ((0.0, -3.5), "Goal refused: the goal"),  # beyond the south wall, off the map
        ("wall", "Goal refused: the goal"),  # in the east wall
        ((0.0, 0.0), "Reached the goal"),  # where the robot stands, facing as it does
    ],
    ids=["off-the-map", "in-a-wall", "under-the-robot"],
)
def test_goals_it_cannot_take_are_answered_in_words_at_once(page: Page, artifacts, where, answer):
    page.click("#live-top")
    page.wait_for_timeout(600)
    live = page.evaluate("window.robotrial.state().live")
    x, _, yaw = live["pose"]
    if where == "wall":
        where = (7.85 - x, 0.0)  # room A's east wall stands at x 7.78 .. 7.93
    at = floor(live, *where)
    drag = floor(live, where[0] + math.cos(yaw), where[1] + math.sin(yaw))
    press(page, "#live-goal", at, drag)
    said = wait_live(page, "(l) => l.status && ['refused', 'reached'].includes(l.status.state)", 45)
    assert said["statusLine"].startswith(answer), said["statusLine"]
    assert "np." not in said["statusLine"]
    if where != (0.0, 0.0):
        # answered at once: refused before any planning or driving, and nothing moved
        assert said["statusHistory"] == ["refused"], said["statusHistory"]
        assert math.dist(said["pose"][:2], live["pose"][:2]) < 0.05
        assert any(w in said["statusLine"] for w in ("off the map", "inside an obstacle")), said
        page.screenshot(path=artifacts / "web_live_refused.png")


def test_a_pose_estimate_goes_out_on_initialpose(server: str, page: Page) -> None:
    import roslibpy

    ros = roslibpy.Ros(host=server.replace("http://", "ws://") + "rosbridge")
    ros.run(timeout=20)
    got, heard = [], threading.Event()
    topic = roslibpy.Topic(ros, "/initialpose", "geometry_msgs/msg/PoseWithCovarianceStamped")
    topic.subscribe(lambda m: (got.append(m), heard.set()))
    try:
        page.click("#live-top")
        page.wait_for_timeout(600)
        live = page.evaluate("window.robotrial.state().live")
        time.sleep(0.5)  # the subscription reaches the server
        press(page, "#live-pose", floor(live, 0.0, 0.0), floor(live, 1.0, 0.0))
        assert heard.wait(10), "no /initialpose"
    finally:
        topic.unsubscribe()
        ros.close()
    p = got[0]["pose"]
    assert got[0]["header"]["frame_id"] == "map"
    assert math.hypot(p["pose"]["position"]["x"], p["pose"]["position"]["y"]) < 8
    assert p["covariance"][0] == pytest.approx(0.25) and p["covariance"][35] > 0
    sent = page.evaluate("window.robotrial.state().live.poseEstimate")
    assert math.dist(sent[:2], live["pose"][:2]) < 0.2


def test_navigate_to_pose_through_the_web_apps_rosbridge(server: str, page: Page) -> None:
    """A ROS 2 client drives the live platform with Nav2's action, on the page's rosbridge."""
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
        # the robot stands where earlier tests left it: 0.6 m ahead of it, on the map
        odom = page.evaluate("window.robotrial.state().live.pose")
        origin = httpx.get(server + "api/config").json()["live"]["origin"]["xyz"]
        x = odom[0] - origin[0] + 0.6 * math.cos(odom[2])
        y = odom[1] - origin[1] + 0.6 * math.sin(odom[2])
        q = {"z": math.sin(odom[2] / 2), "w": math.cos(odom[2] / 2)}
        client = roslibpy.ActionClient(ros, "/navigate_to_pose", "nav2_msgs/action/NavigateToPose")
        done, feedback, answer = threading.Event(), [], {}
        goal = {
            "pose": {
                "header": {"frame_id": "map"},
                "pose": {"position": {"x": x, "y": y}, "orientation": q},
            }
        }
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
