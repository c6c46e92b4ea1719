"""Measuring the real room in AR (iwer's emulated headset, ?xr=emulate, in real Chromium):
with a home drawn in My home (one 4 x 4 m room, the robot's start at (1, 1.5)), the user
places the robot, measures 0.80 m across a doorway on the synthetic floor (the length
shows live while the second end is aimed) and marks it a doorway, then measures the
synthetic counter's front edge 0.9 m up and marks it a counter; a doorway measured in
the middle of the room, far from any wall, is listed with a message. After leaving AR
the editor holds a 0.80 m doorway in the room's west wall and a counter box 0.9 m high
(and names the listed doorway as off the walls until it is removed), after a reload
too, and the downloaded World YAML has both. A second tap aimed at no surface says so
and keeps the first end; two taps on one spot are refused."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from playwright.sync_api import Page

from robotrial.model import load_world
from tests.web.home_plan import gaps_on_line_x

pytestmark = [pytest.mark.browser, pytest.mark.timeout(90)]

HOME = {
    "version": 1,
    "thickness": 0.1,
    "height": 2.0,
    "rooms": [{"name": "Room 1", "corners": [[0, 0], [4, 0], [4, 4], [0, 4]]}],
    "doorways": [],
    "furniture": [],
    "objects": [],
    "spawn": [1.0, 1.5],
}
# The emulated device (web/src/ar/emulate.ts) starts 1.6 m above the floor looking 45
# degrees down: the robot is placed where that view meets the floor, facing the device.
PLACED_GLOBAL = np.array([0.0, 0.0, -1.6])
LOOK_DOWN = [np.sin(-np.pi / 8), 0.0, 0.0, np.cos(-np.pi / 8)]
LOOK_UP = [np.sin(np.pi / 8), 0.0, 0.0, np.cos(np.pi / 8)]


@pytest.fixture(scope="module")
def server(serve) -> str:
    """`robotrial serve` (the desk arm)."""
    return serve()


def measure_state(page: Page) -> dict:
    return page.evaluate("window.robotrial.state().ar.measure")


def tap(page: Page) -> None:
    """A trigger press and release on the right controller: the session's `select`."""
    page.evaluate(
        """async () => {
            const c = window.robotrialXR.controllers.right;
            c.updateButtonValue("trigger", 1);
            await new Promise((r) => setTimeout(r, 100));
            c.updateButtonValue("trigger", 0);
        }"""
    )


def aim(page: Page, target: list[float], offset: np.ndarray) -> None:
    """Move the device so the centre of its view (45 degrees down) meets `target` (global
    space, m) 0.7 m below the eye, and wait until the page's aim is there (`offset`: the
    session's `local` space minus the global one)."""
    x, y, z = target
    page.evaluate(
        "([p, q]) => { const d = window.robotrialXR;"
        " d.position.set(...p); d.quaternion.set(...q); }",
        [[x, y + 0.7, z + 0.7], LOOK_DOWN],
    )
    expected = (np.asarray(target) + offset).tolist()
    page.wait_for_function(
        "(e) => { const a = window.robotrial.state().ar.measure.aim;"
        " return a && a.every((v, i) => Math.abs(v - e[i]) < 1e-3); }",
        arg=expected,
        timeout=5_000,
    )


def shown_length(page: Page) -> float:
    text = page.locator("#ar-measure-length").inner_text()
    match = re.fullmatch(r"(\d+\.\d\d) m", text)
    assert match, text
    return float(match.group(1))


def test_measure_a_doorway_and_a_counter_into_the_home(
    server: str, browser, artifacts: Path, tmp_path: Path
) -> None:
    page = browser.new_page(viewport={"width": 1100, "height": 760}, accept_downloads=True)
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(server)
    page.evaluate(
        "(h) => localStorage.setItem('robotrial.home', h)",
        json.dumps({"home": HOME, "draft": None}),
    )
    page.goto(server + "?xr=emulate")
    page.wait_for_function(
        "() => { const s = window.robotrial && window.robotrial.state();"
        " return s && s.ready && s.ar.session === 'available'; }",
        timeout=30_000,
    )
    page.click("#ar-enter")
    page.wait_for_function("window.robotrial.state().ar.reticle", timeout=10_000)
    assert not page.locator("#ar-measure").is_visible(), "Measure waits for the robot"
    tap(page)
    page.wait_for_function("window.robotrial.state().ar.session === 'placed'", timeout=10_000)
    placed = np.asarray(page.evaluate("window.robotrial.state().ar.placement.xyz"))
    offset = placed - PLACED_GLOBAL

    page.click("#ar-measure")
    assert measure_state(page)["mode"] == "first"

    # A doorway: its two sides on the floor, 0.80 m apart, 1 m behind the robot.
    aim(page, [-0.4, 0.0, -2.6], offset)
    tap(page)
    page.wait_for_function("window.robotrial.state().ar.measure.mode === 'second'")

    # The second tap aimed at the ceiling: no surface there, the first end stays.
    page.evaluate(
        "(q) => window.robotrialXR.quaternion.set(...q)",
        LOOK_UP,
    )
    page.wait_for_function("window.robotrial.state().ar.measure.aim === null")
    tap(page)
    page.wait_for_function("window.robotrial.state().ar.measure.refused")
    state = measure_state(page)
    assert state["mode"] == "second" and len(state["points"]) == 1, state
    assert "No surface where you aim" in page.locator("#ar-hint").inner_text()

    # Aiming at the other side: the line's length shows while aiming, then stays.
    aim(page, [0.4, 0.0, -2.6], offset)
    assert shown_length(page) == pytest.approx(0.80, abs=0.01)
    page.screenshot(path=artifacts / "web_ar_measure_live.png")
    tap(page)
    page.wait_for_function("window.robotrial.state().ar.measure.mode === 'choose'")
    assert shown_length(page) == pytest.approx(0.80, abs=0.01)
    assert measure_state(page)["length"] == pytest.approx(0.80, abs=0.01)
    page.click("#ar-measure-door")
    hint = page.locator("#ar-hint").inner_text()
    assert "Doorway 1, 0.80 m wide" in hint and "Room 1" in hint, hint
    assert measure_state(page)["mode"] == "first"

    # A counter's front edge, 0.9 m up. Two taps on one spot are refused first.
    aim(page, [1.1, 0.9, -1.85], offset)
    tap(page)
    page.wait_for_function("window.robotrial.state().ar.measure.mode === 'second'")
    tap(page)
    page.wait_for_function("window.robotrial.state().ar.measure.refused")
    assert "this measure is refused" in page.locator("#ar-hint").inner_text()
    assert measure_state(page)["mode"] == "second"
    aim(page, [2.1, 0.9, -1.85], offset)
    assert shown_length(page) == pytest.approx(1.00, abs=0.01)
    tap(page)
    page.wait_for_function("window.robotrial.state().ar.measure.mode === 'choose'")
    page.click("#ar-measure-counter")
    hint = page.locator("#ar-hint").inner_text()
    assert "counter added" in hint and "0.90 m high" in hint, hint
    page.screenshot(path=artifacts / "web_ar_measure_done.png")

    # A doorway measured in the middle of the room: no wall there, so it is listed.
    aim(page, [0.1, 0.0, -0.6], offset)
    tap(page)
    page.wait_for_function("window.robotrial.state().ar.measure.mode === 'second'")
    aim(page, [0.9, 0.0, -0.6], offset)
    tap(page)
    page.wait_for_function("window.robotrial.state().ar.measure.mode === 'choose'")
    page.click("#ar-measure-door")
    assert "no wall is drawn there" in page.locator("#ar-hint").inner_text()

    page.click("#ar-exit")
    page.wait_for_function("window.robotrial.state().ar.session === 'available'", timeout=10_000)

    # The home editor holds them, after a reload too (localStorage); the doorway off the
    # walls is named as a problem until it is removed.
    page.click("#home-open-editor")
    problem = page.locator("#home-problems").inner_text()
    assert "Doorway 2 does not sit on a wall" in problem, problem
    page.click("#door-1-remove")
    for reload in (False, True):
        if reload:
            page.reload()
            page.wait_for_function("window.robotrial && window.robotrial.state().ready")
            page.click("#home-open-editor")
        assert page.locator("[id^=row-door-]").count() == 1
        assert float(page.locator("#door-0-width").input_value()) == pytest.approx(0.8, abs=0.01)
        assert float(page.locator("#door-0-x").input_value()) == 0.0
        assert float(page.locator("#furniture-0-height").input_value()) == pytest.approx(
            0.9, abs=0.005
        )
        assert page.locator("#furniture-0-name").input_value() == "counter"
        assert page.locator("#home-problems li.ok").count() == 1
        if not reload:
            page.screenshot(path=artifacts / "web_ar_measure_home.png")
            page.click("#home-close")

    with page.expect_download() as info:
        page.click("#home-download")
    info.value.save_as(tmp_path / "measured.yaml")
    world = load_world(tmp_path / "measured.yaml")
    (gap,) = gaps_on_line_x(world, 0.0)
    assert gap == pytest.approx(0.8, abs=0.01)
    counter = world.body("counter")
    width, depth, height = counter.geometry.size
    assert height == pytest.approx(0.9, abs=0.005)
    assert counter.pose.xyz[2] == pytest.approx(0.45, abs=0.005)
    # The edge ran along the plan's y (the robot's left), 1.00 m long; the counter's 0.6 m
    # depth reaches away from where the user stood.
    assert (width, depth) == (0.6, pytest.approx(1.0, abs=0.01))
    assert not errors, errors
    page.close()
