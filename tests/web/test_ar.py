"""AR in the page with an emulated WebXR device (iwer, loaded by ?xr=emulate): enter an
immersive-ar session, the hit-test against the synthetic floor puts the reticle down, a
tap (`select`) places the robot, and window.robotrial.state().ar says so. Without WebXR
the page says there is no AR and keeps its 3D view."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import Page

pytestmark = [pytest.mark.browser, pytest.mark.timeout(90)]


@pytest.fixture(scope="module")
def server(serve) -> str:
    """`robotrial serve` (the desk arm)."""
    return serve()


def ar_state(page: Page) -> dict:
    return page.evaluate("window.robotrial.state().ar")


def wait_ready(page: Page) -> None:
    page.wait_for_function(
        "() => { const s = window.robotrial && window.robotrial.state();"
        " return s && (s.error || s.ready); }",
        timeout=30_000,
    )
    assert page.evaluate("window.robotrial.state().error") is None


def test_enter_ar_hit_test_and_tap_places_robot(server: str, browser, artifacts: Path) -> None:
    page = browser.new_page(viewport={"width": 1100, "height": 760})
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(server + "?xr=emulate")
    wait_ready(page)
    page.wait_for_function("window.robotrial.state().ar.session === 'available'")
    assert ar_state(page)["placement"] is None

    page.click("#ar-enter")
    page.wait_for_function("window.robotrial.state().ar.session === 'active'", timeout=10_000)
    # The emulated headset looks 45 degrees down from 1.6 m: the reticle meets the floor.
    page.wait_for_function("window.robotrial.state().ar.reticle", timeout=10_000)
    state = ar_state(page)
    assert state["placement"] is None
    assert state["planes"] >= 1, "the synthetic floor is reported by plane detection"
    page.screenshot(path=artifacts / "web_ar_reticle.png")

    # A trigger press and release on the controller is a `select`: the tap.
    page.evaluate(
        """async () => {
            const c = window.robotrialXR.controllers.right;
            c.updateButtonValue("trigger", 1);
            await new Promise((r) => setTimeout(r, 100));
            c.updateButtonValue("trigger", 0);
        }"""
    )
    page.wait_for_function("window.robotrial.state().ar.session === 'placed'", timeout=10_000)
    state = ar_state(page)
    x, y, z = state["placement"]["xyz"]
    # On the floor (y = 0 in the floor-level space, or 1.6 m below the eye in `local`),
    # about 1.6 m ahead of the device, which faces -z.
    assert abs(y - 0.0) < 1e-3 or abs(y + 1.6) < 1e-3, state
    assert abs(x) < 0.05 and -1.8 < z < -1.4, state
    qx, qy, qz, qw = state["placement"]["quat"]
    # The robot's z axis (its up) is the space's y axis (the third column of the rotation).
    z_axis_in_space = np.array(
        [2 * (qx * qz + qw * qy), 2 * (qy * qz - qw * qx), 1 - 2 * (qx * qx + qy * qy)]
    )
    assert abs(z_axis_in_space[1] - 1.0) < 1e-6, z_axis_in_space
    page.screenshot(path=artifacts / "web_ar_placed.png")
    pixels = np.asarray(Image.open(artifacts / "web_ar_placed.png").convert("RGB"), dtype=int)
    assert pixels.std() > 5, "the AR view shows something"

    # The task's buttons ride in the AR bar: Set Robot from there fixes the start.
    assert page.locator("[data-ar-task='#move-robot']").is_visible()
    page.click("[data-ar-task='#set-robot']")
    page.wait_for_function("window.robotrial.state().phase === 'set'", timeout=10_000)

    page.click("#ar-exit")
    page.wait_for_function("window.robotrial.state().ar.session === 'available'", timeout=10_000)
    assert not errors, errors
    page.close()


def test_no_webxr_says_so_and_keeps_3d_view(server: str, browser) -> None:
    page = browser.new_page()
    page.goto(server)
    wait_ready(page)
    page.wait_for_function("window.robotrial.state().ar.session === 'unsupported'")
    assert page.locator("#ar-enter").is_disabled()
    assert "No AR here" in page.locator("#ar-status").inner_text()
    assert page.evaluate("window.robotrial.state().ready")
    page.close()
