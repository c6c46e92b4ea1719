"""The g2rViewer experiment end to end in the browser: `robotrial serve` (with its
planning node) in a subprocess, Debian's headless Chromium through Playwright, the
buttons a user presses, the planner reached through roslibjs and rosbridge, the motion
run by MuJoCo (mujoco-js) in the page. Screenshots and figures go to test-artifacts/."""

from __future__ import annotations

import io
import json
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import Page, sync_playwright

from robotrial.kinematics.chain import Kinematics, default_planning_joints
from robotrial.kinematics.ik import solve_ik
from robotrial.model import load_robot

pytestmark = [pytest.mark.browser, pytest.mark.timeout(150)]

VIEWPORT = {"width": 1280, "height": 800}
# The paper's experiment (Figs. 12 and 13), in the robot's base frame (m).
START = (0.15, -0.15, 0.02)
GOAL = (0.18, 0.2, 0.02)
OBSTACLE = {"x": 20, "y": 0, "z": 15, "width": 10, "depth": 10, "height": 20}  # cm
CONNECTED = """() => { const s = window.robotrial && window.robotrial.state();
    return s && s.ready && s.connection.status === 'connected'; }"""
FINISHED = """() => { const s = window.robotrial.state();
    return (s.run && s.run.status === 'done')
        || ['refused', 'unreachable'].includes(s.planner.status); }"""


@pytest.fixture(scope="module")
def server(serve) -> str:
    """`robotrial serve` with the planning node; the page's URL."""
    return serve()


@pytest.fixture(scope="module")
def start_joints() -> dict[str, float]:
    """Arm joints that put the hand at START pointing down (as a user would set them)."""
    robot = load_robot("desk_arm")
    names = default_planning_joints(robot)
    kin = Kinematics(robot, names)
    target = np.eye(4)
    target[:3, :3] = np.diag([1.0, -1.0, -1.0])
    target[:3, 3] = START
    seed = np.array([-0.8, 0.6, 1.2, 0.0, 1.3, 0.0])
    ik = solve_ik(kin, target, seed, rng=np.random.default_rng(0))
    assert ik.success
    return dict(zip(names, (float(v) for v in ik.q), strict=True))


def open_page(browser, url: str, errors: list[str]) -> Page:
    page = browser.new_page(viewport=VIEWPORT, accept_downloads=True)
    page.on("pageerror", lambda exc: errors.append(str(exc)))
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.goto(url)
    page.wait_for_function(CONNECTED, timeout=30_000)
    return page


def set_joints(page: Page, values: dict[str, float]) -> None:
    """Move the joint sliders as a drag would (an input event per slider)."""
    for name, value in values.items():
        page.evaluate(
            """([name, value]) => {
                const input = document.querySelector(`input[data-joint="${name}"]`);
                input.value = String(value);
                input.dispatchEvent(new Event('input', { bubbles: true }));
            }""",
            [name, value],
        )


def type_into(page: Page, selector: str, value: float) -> None:
    field = page.locator(selector)
    field.fill(str(value))
    field.dispatch_event("change")


def arrange_experiment(page: Page, start_joints: dict[str, float], goal=GOAL) -> None:
    """The paper's steps 1 to 3: obstacle C, object B in the hand, the goal."""
    set_joints(page, start_joints)
    page.click("#add-obstacle")
    row = page.locator("[data-obstacle]").first
    for field, value in OBSTACLE.items():
        type_into(page, f"[data-obstacle] input[data-field={field}] >> nth=0", value)
    assert row.locator("input[data-field=height]").input_value() == "20.0"
    page.locator("summary", has_text="Object to carry").click()
    page.check("#carry-object")
    page.locator("summary", has_text="Goal for the hand").click()
    for axis, value in zip("xyz", goal, strict=True):
        type_into(page, f"#goal-{axis}", round(value * 100, 1))


def view_pixels(page: Page, path: Path) -> np.ndarray:
    page.screenshot(path=path)
    canvas = page.locator("#view canvas").screenshot()
    return np.asarray(Image.open(io.BytesIO(canvas)).convert("RGB"), dtype=int)


def test_experiment_through_the_buttons(
    server: str,
    chromium: str,
    chromium_args: list[str],
    artifacts: Path,
    start_joints: dict[str, float],
    tmp_path: Path,
) -> None:
    errors: list[str] = []
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=chromium, args=chromium_args)
        started = time.perf_counter()
        page = open_page(browser, server, errors)
        seen_ready_s = time.perf_counter() - started
        # The page's own measures, from navigation start (ms): drawn, and connected.
        timing = page.evaluate(
            """() => Object.fromEntries(performance.getEntriesByType('measure')
                .map(m => [m.name.split(' ')[0], m.startTime + m.duration]))"""
        )
        state = page.evaluate("window.robotrial.state()")
        assert state["phase"] == "editing"
        assert state["ar"] is not None
        assert state["connection"]["url"].endswith("/rosbridge")

        arrange_experiment(page, start_joints)
        state = page.evaluate("window.robotrial.state()")
        np.testing.assert_allclose(state["endEffector"], START, atol=1e-3)
        (obstacle,) = state["obstacles"]
        np.testing.assert_allclose(obstacle["position"], [0.2, 0, 0.15], atol=1e-9)
        np.testing.assert_allclose(obstacle["size"], [0.1, 0.1, 0.2], atol=1e-9)
        assert np.linalg.norm(np.subtract(state["object"]["position"], START)) < 0.02
        np.testing.assert_allclose(state["goal"], GOAL, atol=1e-9)
        view_pixels(page, artifacts / "web_experiment_arranged.png")

        page.click("#set-robot")
        assert "in the hand" in page.inner_text("#task-message")
        assert page.locator('input[data-joint="joint1"]').is_disabled()
        assert page.evaluate("window.robotrial.state()")["object"]["held"] is True

        page.click("#move-robot")
        page.wait_for_function(FINISHED, timeout=90_000)
        state = page.evaluate("window.robotrial.state()")
        planner = state["planner"]
        assert planner["status"] == "planned", planner["message"]
        run = state["run"]
        # The hand ends within 1 cm of the goal, nothing touched obstacle C, and the
        # browser's hand followed the planned one.
        assert run["finalError"] <= 0.01, run
        assert run["contacts"] == [] and run["contactSteps"] == 0, run["contacts"]
        assert run["rmsGap"] < 0.01, run
        np.testing.assert_allclose(state["endEffector"], GOAL, atol=0.01)
        # The object came along in the hand.
        assert np.linalg.norm(np.subtract(state["object"]["position"], GOAL)) < 0.03
        assert "Done" in page.inner_text("#task-message")
        assert page.locator("#path-plot").is_visible()
        done = view_pixels(page, artifacts / "web_experiment_done.png")
        assert (np.abs(done - done[2, 2]).sum(axis=2) > 30).mean() > 0.05

        # The plot exports as CSV (one row per 10 ms sample) and PNG.
        with page.expect_download() as got:
            page.click("#export-csv")
        csv = tmp_path / "path.csv"
        got.value.save_as(csv)
        rows = np.loadtxt(csv, delimiter=",", skiprows=1)
        assert csv.read_text().startswith("t,planned_x,planned_y,planned_z,browser_x")
        assert len(rows) == run["samples"]
        gap = np.linalg.norm(rows[:, 1:4] - rows[:, 4:7], axis=1)
        assert np.sqrt(np.mean(gap**2)) == pytest.approx(run["rmsGap"], abs=1e-5)
        with page.expect_download() as got:
            page.click("#export-png")
        png = artifacts / "web_experiment_path.png"
        got.value.save_as(png)
        chart = np.asarray(Image.open(png).convert("RGB"), dtype=int)
        assert chart.shape[1] >= 1000
        assert (np.abs(chart - [255, 255, 255]).sum(axis=2) > 60).mean() > 0.02

        # The chart is docked under the 3D view, never over it, and folds to its title.
        canvas, card = page.locator("#view canvas"), page.locator("#path-plot")
        view_box, card_box = canvas.bounding_box(), card.bounding_box()
        assert card_box["y"] >= view_box["y"] + view_box["height"] - 1, (view_box, card_box)
        page.click("#plot-fold")
        assert not page.locator("#path-plot .chart").is_visible()
        page.wait_for_function(
            f"document.querySelector('#view canvas').clientHeight > {view_box['height'] + 50}"
        )
        page.click("#plot-fold")
        assert page.locator("#path-plot .chart").is_visible()

        # Reset Robot: back to the start, editable again, the chart gone.
        page.click("#reset-robot")
        assert not card.is_visible()
        state = page.evaluate("window.robotrial.state()")
        assert state["phase"] == "editing"
        np.testing.assert_allclose(state["endEffector"], START, atol=1e-3)
        assert not page.locator('input[data-joint="joint1"]').is_disabled()

        # A goal the planner refuses brings no chart back.
        for axis, value in zip("xyz", (0.9, 0.0, 0.02), strict=True):
            type_into(page, f"#goal-{axis}", round(value * 100, 1))
        page.click("#move-robot")
        page.wait_for_function(FINISHED, timeout=60_000)
        assert page.evaluate("window.robotrial.state()")["planner"]["status"] == "refused"
        assert not card.is_visible()

        speed = page.evaluate("window.robotrial.measurePhysics(1.5)")
        browser.close()
    assert errors == [], errors
    figures = {
        "page_ready_s": round(timing["robotrial:ready"] / 1000, 3),
        "page_connected_s": round(timing["robotrial:connected"] / 1000, 3),
        "ready_and_connected_seen_by_test_s": round(seen_ready_s, 3),
        "planning_time_s": round(planner["planningTime"], 3),
        "final_error_m": run["finalError"],
        "rms_gap_m": run["rmsGap"],
        "max_gap_m": run["maxGap"],
        "motion_sim_s": run["simTime"],
        "motion_wall_s": run["wallTime"],
        "mujoco_steps_per_s": round(speed["stepsPerSecond"]),
        "mujoco_real_time_factor": round(speed["realTimeFactor"], 2),
    }
    (artifacts / "web_experiment.json").write_text(json.dumps(figures, indent=2) + "\n")


def test_planner_refusal_scene_file_and_connection(
    server: str,
    chromium: str,
    chromium_args: list[str],
    artifacts: Path,
    start_joints: dict[str, float],
    tmp_path: Path,
) -> None:
    errors: list[str] = []
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=chromium, args=chromium_args)
        page = open_page(browser, server, errors)
        arrange_experiment(page, start_joints, goal=(0.9, 0.0, 0.02))

        # Boxes stay on the table, whatever number is typed ...
        type_into(page, "[data-obstacle] input[data-field=z] >> nth=0", -30)
        state = page.evaluate("window.robotrial.state()")
        assert state["obstacles"][0]["position"][2] == pytest.approx(0.1)
        type_into(page, "[data-obstacle] input[data-field=z] >> nth=0", 15)
        # ... or however far the gizmo's up-down arrow (pure blue) is dragged down.
        page.click("[data-obstacle] [data-action=select]")
        pixels = view_pixels(page, artifacts / "web_experiment_gizmo.png")
        blue = (pixels[..., 2] > 200) & (pixels[..., 0] < 60) & (pixels[..., 1] < 60)
        ys, xs = np.nonzero(blue)
        assert len(ys) > 20, "no gizmo drawn on the selected obstacle"
        upper = ys < np.median(ys)
        box = page.locator("#view canvas").bounding_box()
        x, y = box["x"] + xs[upper].mean(), box["y"] + ys[upper].mean()
        page.mouse.move(x, y)
        page.mouse.down()
        for step in range(1, 13):
            page.mouse.move(x, y + 25 * step)
        page.mouse.up()
        dragged = page.evaluate("window.robotrial.state()")["obstacles"][0]
        assert dragged["position"][2] == pytest.approx(0.1), dragged
        assert page.locator("[data-obstacle] input[data-field=z]").input_value() == "10.0"
        type_into(page, "[data-obstacle] input[data-field=z] >> nth=0", 15)

        # A goal out of reach: the planner says no, in words, and nothing moves.
        page.click("#move-robot")
        page.wait_for_function(FINISHED, timeout=60_000)
        state = page.evaluate("window.robotrial.state()")
        assert state["planner"]["status"] == "refused"
        assert "out of reach" in state["planner"]["message"]
        message = page.inner_text("#task-message")
        assert message.startswith("The planner says no: the goal is out of the arm's reach")
        assert state["run"] is None
        np.testing.assert_allclose(state["endEffector"], START, atol=1e-3)
        view_pixels(page, artifacts / "web_experiment_refused.png")

        # Save the scene, change everything, load it back.
        page.click("#reset-robot")
        page.locator("summary", has_text="Scene file").click()
        with page.expect_download() as got:
            page.click("#save-scene")
        scene = tmp_path / "scene.json"
        got.value.save_as(scene)
        saved = json.loads(scene.read_text())
        assert saved["format"] == "robotrial-scene" and saved["robot"] == "desk_arm"
        before = page.evaluate("window.robotrial.state()")
        page.click("[data-obstacle] [data-action=delete]")
        page.uncheck("#carry-object")
        set_joints(page, {"joint1": 0.0, "joint2": 0.0})
        assert page.evaluate("window.robotrial.state()")["obstacles"] == []
        page.set_input_files("#scene-file", str(scene))
        page.wait_for_function("window.robotrial.state().obstacles.length === 1")
        after = page.evaluate("window.robotrial.state()")
        for box in ("position", "size", "quaternion"):
            np.testing.assert_allclose(after["obstacles"][0][box], before["obstacles"][0][box])
            np.testing.assert_allclose(after["object"][box], before["object"][box])
        assert after["goal"] == before["goal"]
        np.testing.assert_allclose(after["joints"]["values"], before["joints"]["values"])

        # A broken scene file is refused with a reason.
        broken = tmp_path / "broken.json"
        broken.write_text(json.dumps({**saved, "goal": [1, 2]}))
        page.set_input_files("#scene-file", str(broken))
        page.wait_for_function("document.querySelector('#task-message').dataset.kind === 'error'")
        assert '"goal" must be a list of 3 numbers' in page.inner_text("#task-message")

        # Another rosbridge URL: nothing listens there, so the page says so and retries;
        # pointed back, it connects again.
        page.locator("summary", has_text="Connection").click()
        page.fill("#rosbridge-url", "ws://127.0.0.1:9/rosbridge")
        page.click("#rosbridge-connect")
        page.wait_for_function("window.robotrial.state().connection.attempts >= 2", timeout=20_000)
        state = page.evaluate("window.robotrial.state()")
        assert state["connection"]["status"] != "connected"
        assert page.locator("#connection").inner_text() != "Connected"
        assert page.locator("#move-robot").is_disabled()
        view_pixels(page, artifacts / "web_experiment_disconnected.png")
        page.fill("#rosbridge-url", server.replace("http", "ws") + "rosbridge")
        page.click("#rosbridge-connect")
        page.wait_for_function(CONNECTED, timeout=20_000)
        assert page.locator("#connection").inner_text() == "Connected"
        browser.close()
    # The refused connection is logged by the browser itself; nothing else may fail.
    assert [e for e in errors if "127.0.0.1:9" not in e] == []


def test_another_arm_of_the_list_plans_through_its_own_service(
    server: str, chromium: str, chromium_args: list[str]
) -> None:
    """Move Robot! works for every arm the server lists, not only its default robot."""
    errors: list[str] = []
    goal = (0.25, 0.1, 0.2)
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=chromium, args=chromium_args)
        page = open_page(browser, f"{server}?robot=manipulator_h&world=desk", errors)
        assert not page.locator("#move-robot").is_disabled()
        assert "No planner" not in page.inner_text("#task-message")
        page.locator("summary", has_text="Goal for the hand").click()
        for axis, value in zip("xyz", goal, strict=True):
            type_into(page, f"#goal-{axis}", round(value * 100, 1))
        page.click("#set-robot")
        page.click("#move-robot")
        page.wait_for_function(FINISHED, timeout=90_000)
        state = page.evaluate("window.robotrial.state()")
        browser.close()
    assert state["planner"]["status"] == "planned", state["planner"]["message"]
    assert state["run"]["finalError"] <= 0.01, state["run"]
    np.testing.assert_allclose(state["endEffector"], goal, atol=0.01)
    assert errors == [], errors
