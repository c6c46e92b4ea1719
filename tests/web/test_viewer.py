"""The page end to end: `robotrial serve` in a subprocess, Debian's headless Chromium
through Playwright, screenshots kept in test-artifacts/."""

from __future__ import annotations

import io
import json
import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import Page, sync_playwright

from robotrial.kinematics.reference import link_poses
from robotrial.model import load_robot

pytestmark = [pytest.mark.browser, pytest.mark.timeout(90)]

VIEWPORT = {"width": 1280, "height": 800}


@pytest.fixture
def server(serve) -> str:
    """`robotrial serve` (the desk arm on the desk)."""
    return serve()


def wait_ready(page: Page, robot: str, world: str) -> dict:
    """Wait until the page shows `robot` in `world`; the state, failing on a load error."""
    page.wait_for_function(
        """([robot, world]) => {
            const s = window.robotrial && window.robotrial.state();
            return s && (s.error || (s.ready && s.robot === robot && s.world === world));
        }""",
        arg=[robot, world],
        timeout=30_000,
    )
    state = page.evaluate("window.robotrial.state()")
    assert state["error"] is None, state["error"]
    return state


def snapshot(page: Page, path: Path) -> np.ndarray:
    """Save a screenshot of the page to `path`; the 3D view's pixels as an int RGB array."""
    page.screenshot(path=path)
    canvas = page.locator("#view canvas").screenshot()
    return np.asarray(Image.open(io.BytesIO(canvas)).convert("RGB"), dtype=int)


def centre(pixels: np.ndarray, fraction: float = 0.5) -> np.ndarray:
    h, w = pixels.shape[:2]
    dh, dw = int(h * fraction / 2), int(w * fraction / 2)
    return pixels[h // 2 - dh : h // 2 + dh, w // 2 - dw : w // 2 + dw]


def drawn_fraction(pixels: np.ndarray) -> float:
    """Share of the view's centre, where the page frames the robot, that differs from
    the background (the top-left pixel)."""
    background = pixels[2, 2]
    region = centre(pixels)
    return float((np.abs(region - background).sum(axis=2) > 30).mean())


def test_page_shows_moves_and_switches_robots(
    server: str, chromium: str, chromium_args: list[str], artifacts: Path
) -> None:
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=chromium, args=chromium_args)
        page = browser.new_page(viewport=VIEWPORT)
        errors: list[str] = []
        page.on("pageerror", lambda exc: errors.append(str(exc)))
        page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)

        start = time.perf_counter()
        page.goto(server)
        state = wait_ready(page, "desk_arm", "desk")
        ready_s = time.perf_counter() - start
        assert state["joints"]["names"][:6] == [f"joint{i}" for i in range(1, 7)]
        assert len(state["joints"]["values"]) == len(state["joints"]["names"])
        assert len(state["endEffector"]) == 3

        # state() is a copy: changing it changes nothing on the page.
        assert page.evaluate(
            """() => { const s = window.robotrial.state();
                       try { s.joints.values[0] = 99; } catch {}
                       return window.robotrial.state().joints.values[0] !== 99; }"""
        )

        home_pixels = snapshot(page, artifacts / "web_desk_arm_desk.png")
        assert drawn_fraction(home_pixels) > 0.05, "the 3D view is blank"

        # A user drags the shoulder slider most of the way up.
        slider = page.locator('input[data-joint="joint2"]')
        box = slider.bounding_box()
        assert box is not None
        page.mouse.click(box["x"] + 0.85 * box["width"], box["y"] + box["height"] / 2)
        page.wait_for_function("window.robotrial.state().joints.values[1] !== 0")
        moved = page.evaluate("window.robotrial.state()")
        assert moved["joints"]["values"][1] > 0.3
        assert moved["joints"]["values"][0] == state["joints"]["values"][0]
        shift = np.linalg.norm(np.subtract(moved["endEffector"], state["endEffector"]))
        assert shift > 0.02, f"end effector moved {shift:.4f} m"
        # The page's forward kinematics agree with the reference FK.
        model = load_robot("desk_arm")
        q = dict(zip(moved["joints"]["names"], moved["joints"]["values"], strict=True))
        expected = link_poses(model, q)[model.end_effector][:3, 3]
        np.testing.assert_allclose(moved["endEffector"], expected, atol=1e-6)
        shown = page.locator("#end-effector [data-axis=z]").inner_text()
        assert shown == f"{moved['endEffector'][2] * 100:.1f} cm"

        bent_pixels = snapshot(page, artifacts / "web_desk_arm_moved.png")
        changed = np.abs(bent_pixels - home_pixels).sum(axis=2) > 30
        assert changed.mean() > 0.002, "the robot on screen did not move"

        page.get_by_role("button", name="Home position").click()
        page.wait_for_function("window.robotrial.state().joints.values.every(v => v === 0)")
        back = page.evaluate("window.robotrial.state()")
        np.testing.assert_allclose(back["endEffector"], state["endEffector"], atol=1e-9)
        assert page.locator('input[data-joint="joint2"]').input_value() == "0"

        # Switch to the mobile manipulator: it opens in room A.
        start = time.perf_counter()
        page.select_option("#robot-picker", "mobile_manipulator")
        mobile = wait_ready(page, "mobile_manipulator", "room_a")
        switch_s = time.perf_counter() - start
        assert "arm_joint1" in mobile["joints"]["names"]
        places = page.locator("#world-picker option").evaluate_all("os => os.map(o => o.value)")
        assert {"room_a", "room_b", "room_c", "apartment"} <= set(places)
        assert "desk" not in places
        room_pixels = snapshot(page, artifacts / "web_mobile_manipulator_room_a.png")
        assert drawn_fraction(room_pixels) > 0.05

        # Another place for the same robot: the robot stays, the room changes.
        page.select_option("#world-picker", "apartment")
        home = wait_ready(page, "mobile_manipulator", "apartment")
        assert home["joints"] == mobile["joints"]
        flat_pixels = snapshot(page, artifacts / "web_mobile_manipulator_apartment.png")
        assert drawn_fraction(flat_pixels) > 0.05

        browser.close()
    assert errors == []
    (artifacts / "web_timing.json").write_text(
        json.dumps({"page_ready_s": round(ready_s, 3), "switch_s": round(switch_s, 3)}) + "\n"
    )


def test_with_a_token_the_page_opens_only_from_its_link(serve, browser, artifacts: Path) -> None:
    """`serve --token`: the page opened from the printed link loads the robot (the link's
    token comes back as a cookie for the page's own requests); without it the page says
    what to do, and the API and rosbridge refuse a reader without the token."""
    import httpx

    token = "a-token-for-the-page"
    url = serve("--token", token)
    api = httpx.Client(base_url=url, timeout=30)
    assert api.get("api/worlds").status_code == 401
    assert api.get("openapi.json").status_code == 401
    assert api.get("api/robots/desk_arm.glb").status_code == 401
    assert api.get("api/worlds", headers={"Authorization": f"Bearer {token}"}).status_code == 200
    assert api.get("api/config", headers={"Host": "evil.example"}).status_code == 400
    assert api.get("", headers={"Host": "evil.example"}).status_code == 400

    page = browser.new_page(viewport=VIEWPORT)
    page.goto(f"{url}?token={token}")
    wait_ready(page, "desk_arm", "desk")
    page.wait_for_function(
        "window.robotrial.state().connection.status === 'connected'", timeout=30_000
    )
    page.screenshot(path=artifacts / "viewer_token.png")
    page.close()

    page = browser.new_page(viewport=VIEWPORT)
    page.goto(url)
    page.wait_for_function("window.robotrial && window.robotrial.state().error", timeout=30_000)
    assert "needs its token" in page.evaluate("window.robotrial.state().error")
    page.close()
