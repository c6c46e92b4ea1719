"""Check my home, in the page: a household draws two rooms with a 0.6 m doorway between
them and checks the home with the mobile manipulator (0.67 m wide): the second room is
red and unreachable, in the verdict's table and on the editor's own plan, where the
doorway is red too; widened to 0.9 m and checked again, the second room is reachable.
Then the same home for two robots side by side: one column each, with their summaries and
floor plans. A narrower robot uploaded to the server passes the 0.6 m doorway where the
mobile manipulator does not: the room that differs is marked in both columns. A doorway
in an outer wall: the check says the home is not closed, in Room 2. The drawing is the
same after every check, and survives a reload."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
from playwright.sync_api import Page, sync_playwright

from tests.web.home_plan import click_at, download, draw_room

pytestmark = [pytest.mark.timeout(120), pytest.mark.browser]

CHECK_TIMEOUT_MS = 90_000
LITTLE_BASE = """<?xml version="1.0"?>
<robot name="little_base">
  <link name="base_link">
    <inertial>
      <mass value="10"/><inertia ixx="0.2" iyy="0.3" izz="0.4" ixy="0" ixz="0" iyz="0"/>
    </inertial>
    <collision><origin xyz="0 0 0.1"/><geometry><box size="0.5 0.4 0.2"/></geometry></collision>
  </link>
  <robotrial>
    <drive type="skid_steer" max_speed="0.5" max_accel="1.0" max_yaw_rate="2.0"
           wheel_separation="0.3" wheel_radius="0.05"/>
  </robotrial>
</robot>
"""
"""A 0.5 x 0.4 m box on wheels: narrower than the 0.6 m doorway."""


@pytest.fixture(scope="module")
def server(serve) -> str:
    """`robotrial serve` (the desk arm; the check picks its own robots)."""
    return serve()


@pytest.fixture(scope="module")
def page(server: str, chromium: str, chromium_args: list[str]) -> Iterator[Page]:
    """The page with a two-room home drawn: rooms of 4 x 3 and 3 x 3 m sharing the wall
    at x = 4 m, a 0.6 m doorway in it; the editor open."""
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=chromium_args)
        page = browser.new_page(viewport={"width": 1400, "height": 900})
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(server)
        page.wait_for_function("window.robotrial && window.robotrial.state().ready")
        page.click("#home-open-editor")
        page.click("#home-tool-room")
        draw_room(page, [(0, 0), (4, 0), (4, 3), (0, 3)])
        draw_room(page, [(4, 0), (7, 0), (7, 3), (4, 3)])
        page.click("#home-tool-door")
        page.fill("#home-door-width", "0.6")
        click_at(page, 4.02, 1.5)
        page.click("#home-tool-select")
        assert page.locator("#home-problems li.ok").count() == 1
        yield page
        assert not errors, errors
        browser.close()


def check(page: Page) -> None:
    """Press Check my home; wait for the verdict (the progress bar shows meanwhile)."""
    page.click("#home-check")
    page.wait_for_selector("#verdict[data-state='running'] #verdict-progress")
    page.wait_for_selector(
        "#verdict[data-state='done'], #verdict[data-state='failed']", timeout=CHECK_TIMEOUT_MS
    )
    assert page.get_attribute("#verdict", "data-state") == "done", page.inner_text("#verdict-what")


def room_row(page: Page, robot: str, room: str):
    return page.locator(f".verdict-column[data-robot='{robot}'] tr[data-room='{room}']")


def test_a_narrow_doorway_leaves_the_second_room_red_until_widened(
    page: Page, artifacts: Path
) -> None:
    page.select_option("#verdict-robot", "mobile_manipulator")
    page.select_option("#verdict-compare", "")
    check(page)
    column = page.locator(".verdict-column")
    assert column.count() == 1 and column.get_attribute("data-robot") == "mobile_manipulator"
    summary = page.inner_text("#verdict-what")  # the line at the top
    assert summary.startswith("fits: 1 of 2 rooms") and "Room 2" in summary, summary
    second = room_row(page, "mobile_manipulator", "Room 2")
    assert second.get_attribute("data-colour") == "red"
    assert "no" in second.locator("td").all_inner_texts()  # reachable: no
    assert room_row(page, "mobile_manipulator", "Room 1").get_attribute("data-colour") != "red"
    assert page.locator(".verdict-picture").first.evaluate("img => img.naturalWidth") > 100
    # The editor's own plan: the second room and the doorway red, the first not.
    assert "verdict-red" in page.get_attribute("#home-plan polygon[data-item='room-1']", "class")
    assert "verdict-red" not in page.get_attribute(
        "#home-plan polygon[data-item='room-0']", "class"
    )
    assert "verdict-red" in page.get_attribute("#home-plan circle[data-item='door-0']", "class")
    page.screenshot(path=artifacts / "web_verdict_narrow.png")

    page.fill("#door-0-width", "0.9")
    page.press("#door-0-width", "Enter")
    # The plan's colours belong to the checked home: hidden once it changes.
    page.wait_for_selector("#verdict-stale:not([hidden])")
    assert "verdict" not in page.get_attribute("#home-plan polygon[data-item='room-1']", "class")
    check(page)
    second = room_row(page, "mobile_manipulator", "Room 2")
    assert second.get_attribute("data-colour") in ("green", "amber")
    assert "yes" in second.locator("td").all_inner_texts()
    assert page.inner_text("#verdict-what").startswith("fits: 2 of 2 rooms")
    assert "verdict-red" not in page.get_attribute("#home-plan circle[data-item='door-0']", "class")
    assert page.locator("#home-plan polyline.route").count() == 2
    page.screenshot(path=artifacts / "web_verdict_wide.png")


def test_two_robots_side_by_side_and_the_drawing_kept(page: Page, artifacts: Path) -> None:
    page.select_option("#verdict-robot", "mobile_manipulator")
    page.select_option("#verdict-compare", "husky")
    check(page)
    columns = page.locator(".verdict-column")
    assert [columns.nth(i).get_attribute("data-robot") for i in range(2)] == [
        "mobile_manipulator",
        "husky",
    ]
    boxes = [columns.nth(i).bounding_box() for i in range(2)]
    assert boxes[0]["x"] + boxes[0]["width"] <= boxes[1]["x"] + 1  # side by side
    top = page.inner_text("#verdict-what")
    assert top.startswith("Mobile manipulator: fits: 2 of 2") and "Husky: fits: 2 of 2" in top
    for i in range(2):
        assert columns.nth(i).locator(".verdict-summary").inner_text().startswith("fits: 2 of 2")
        assert columns.nth(i).locator("tr[data-room]").count() == 2
        assert columns.nth(i).locator(".verdict-picture").count() == 1
    # The two bases measure the same, so nothing differs, and the page says so.
    assert page.locator("#verdict-differences").inner_text() == (
        "Both robots reach the same rooms, with the same colours."
    )
    page.screenshot(path=artifacts / "web_verdict_two_robots.png")

    page.reload()
    page.wait_for_function("window.robotrial && window.robotrial.state().ready")
    page.click("#home-open-editor")
    assert page.locator("#home-plan polygon.room").count() == 2
    assert page.locator("#door-0-width").input_value() == "0.9"


def test_a_room_one_robot_reaches_and_the_other_not_is_marked(
    server: str, page: Page, artifacts: Path
) -> None:
    answer = httpx.post(
        server + "api/robots/upload",
        files={"file": ("little_base.urdf", LITTLE_BASE.encode())},
        timeout=60,
    )
    assert answer.status_code == 201, answer.text
    page.click("#home-close")
    page.click("#home-open-editor")  # the pickers list the robots the server has now
    page.wait_for_selector("#verdict-compare option[value='little_base']", state="attached")
    page.fill("#door-0-width", "0.6")
    page.press("#door-0-width", "Enter")
    page.select_option("#verdict-robot", "mobile_manipulator")
    page.select_option("#verdict-compare", "little_base")
    check(page)
    assert page.locator("#verdict-differences").inner_text() == "Only Little base reaches Room 2."
    for robot, colour in (("mobile_manipulator", "red"), ("little_base", "amber")):
        row = room_row(page, robot, "Room 2")
        assert row.get_attribute("data-colour") == colour
        assert "differs" in row.get_attribute("class")
        assert "differs" not in (room_row(page, robot, "Room 1").get_attribute("class") or "")
    page.screenshot(path=artifacts / "web_verdict_differences.png")


def test_a_doorway_to_the_outside_is_named_and_the_drawing_kept(page: Page) -> None:
    page.click("#home-tool-door")
    page.fill("#home-door-width", "0.9")
    click_at(page, 7.02, 1.5)  # in Room 2's east wall, the outer one
    page.click("#home-tool-select")
    page.click("#home-check")
    page.wait_for_selector("#verdict[data-state='failed']", timeout=CHECK_TIMEOUT_MS)
    message = page.inner_text("#verdict-what")
    assert "the home is not closed" in message and "Room 2" in message, message
    assert page.get_attribute("#verdict-what", "role") == "alert"
    assert page.locator("#home-plan circle.door").count() == 2  # nothing lost
    page.click("#home-undo")
    assert page.locator("#home-plan circle.door").count() == 1


def test_a_chore_picked_in_the_page_comes_back_with_its_result(
    page: Page, artifacts: Path, tmp_path: Path
) -> None:
    """An object on the floor of Room 1, the chore "take it to Room 2" added in the Chores
    picker: the verdict lists the chore with the carry trial's answer. A table in Room 1
    becomes its place to set things down, 0.12 m in from the edge facing the room's
    middle; Room 2 has no furniture, so nowhere to set things down: the trial refuses at
    once and the page says why (a chore the trial runs takes about a minute of server
    time; see tests/trials/test_carry_route.py)."""
    page.click("#home-tool-object")
    click_at(page, 1.0, 1.0)
    page.click("#home-tool-furniture")
    page.select_option("#home-preset", "table")  # 1.2 x 0.8 m, 0.75 m high
    click_at(page, 2.0, 2.4)
    page.click("#home-tool-select")
    world = download(page, tmp_path / "chores.yaml")
    first, second = world.room("Room 1"), world.room("Room 2")
    assert first.place_on == "table" and second.place is None
    assert first.place == pytest.approx((2.0, 2.4 - 0.4 + 0.12), abs=0.06)
    page.click("#chores summary")
    page.wait_for_selector("#chore-object option[value='object_1']", state="attached")
    page.select_option("#chore-object", "object_1")
    page.select_option("#chore-room", "Room 2")
    page.click("#chore-add")
    page.click("#chore-add")  # the same chore twice is kept once
    assert page.locator("#chore-list li").all_inner_texts() == ["object 1 to Room 2 ×"]
    page.select_option("#chore-room", "Room 1")
    page.click("#chore-add")
    assert page.locator("#chore-list li").count() == 2
    page.locator("#chore-list li[data-chore='object_1:Room 1'] .chore-remove").click()
    assert page.locator("#chore-list li").count() == 1
    page.select_option("#verdict-robot", "mobile_manipulator")
    page.select_option("#verdict-compare", "")
    check(page)
    result = page.locator(
        ".verdict-column[data-robot='mobile_manipulator'] .verdict-chore-results li"
    )
    assert result.count() == 1 and result.get_attribute("data-done") == "no"
    text = result.inner_text()
    assert text.startswith("object_1 to Room 2: not tried:"), text
    assert "room 'Room 2' has no place to set things down" in text, text
    assert page.inner_text("#verdict-what").endswith("chores: 0 of 1")
    page.screenshot(path=artifacts / "web_verdict_chore.png")
