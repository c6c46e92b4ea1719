"""My home, in the page: a household draws two rooms sharing a wall, a 0.6 m doorway, a
table and a cup on it with the clicks a user would make; the YAML it downloads loads as
a world with two rooms and a 0.6 m gap in the shared wall; the doorway widened to 0.9 m
by typing survives a reload (localStorage); sent to the server the home joins the world
picker with a robot in it; a room left open, overlapping furniture and a width that is
not a number get a message, and undo/redo take changes back and forth."""

from __future__ import annotations

from pathlib import Path

import pytest
from PIL import Image
from playwright.sync_api import sync_playwright

from tests.web.home_plan import click_at, download, draw_room, gaps_on_line_x

pytestmark = [pytest.mark.timeout(120)]


@pytest.fixture(scope="module")
def server(serve) -> str:
    """`robotrial serve` (the desk arm)."""
    return serve()


@pytest.mark.browser
def test_draw_save_reload_and_send_a_home(
    server: str, chromium: str, chromium_args: list[str], artifacts: Path, tmp_path: Path
) -> None:
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=chromium_args)
        page = browser.new_page(viewport={"width": 1400, "height": 900}, accept_downloads=True)
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
        page.click("#home-tool-furniture")
        page.select_option("#home-preset", "table")
        click_at(page, 5.5, 1.5)
        page.click("#home-tool-object")
        click_at(page, 5.5, 1.5)
        page.fill("#object-0-name", "cup")
        page.press("#object-0-name", "Enter")
        assert page.locator("#home-problems li.ok").count() == 1
        page.screenshot(path=artifacts / "web_home_drawn.png")

        world = download(page, tmp_path / "my_home.yaml")
        assert [r.name for r in world.rooms] == ["Room 1", "Room 2"]
        assert world.rooms[0].bounds == ((0.0, 0.0), (4.0, 3.0))
        assert gaps_on_line_x(world, 4.0) == [0.6]
        assert gaps_on_line_x(world, 0.0) == [] and gaps_on_line_x(world, 7.0) == []
        table = world.body("table")
        assert table.geometry.size == (1.2, 0.8, 0.75) and table.pose.xyz == (5.5, 1.5, 0.375)
        assert world.body("cup").pose.xyz[2] == pytest.approx(0.79)  # on the table

        page.fill("#door-0-width", "0.9")
        page.press("#door-0-width", "Enter")
        page.wait_for_function("document.getElementById('door-0-width').value === '0.9'")

        # A width that is not a number: a message naming the doorway, nothing changed.
        page.fill("#door-0-width", "wide")
        page.press("#door-0-width", "Enter")
        message = page.locator("#home-message").inner_text()
        assert "“wide” is not a number" in message and "Doorway 1" in message, message
        assert page.locator("#door-0-width").input_value() == "0.9"

        page.reload()
        page.wait_for_function("window.robotrial && window.robotrial.state().ready")
        page.click("#home-open-editor")
        assert page.locator("#home-plan polygon.room").count() == 2
        assert page.locator("#door-0-width").input_value() == "0.9"
        world = download(page, tmp_path / "wider.yaml")
        assert gaps_on_line_x(world, 4.0) == [0.9]

        # New home, then the downloaded YAML opened again; a YAML not drawn here is refused.
        page.click("#home-clear")
        assert page.locator("#home-plan polygon.room").count() == 0
        page.set_input_files("#home-open", str(tmp_path / "wider.yaml"))
        page.wait_for_selector("#home-plan polygon.room >> nth=1")
        assert page.locator("#door-0-width").input_value() == "0.9"
        other = tmp_path / "room.yaml"
        other.write_text("walls: []\n")
        page.set_input_files("#home-open", str(other))
        page.wait_for_selector("#home-message:has-text('room.yaml has no home section')")
        assert page.locator("#home-plan polygon.room").count() == 2

        page.click("#home-send")
        page.wait_for_selector("#home-message[data-status='ready']", timeout=60_000)
        page.click("#home-close")
        page.wait_for_function(
            "(() => { const s = window.robotrial.state();"
            " return s.error || (s.ready && s.world === 'my_home'); })()",
            timeout=60_000,
        )
        assert page.evaluate("window.robotrial.state().error") is None
        assert page.locator("#world-picker option[value='my_home']").count() == 1
        page.screenshot(path=artifacts / "web_home_sent.png")

        # A room left open: download refuses with the message; undo takes the corners back.
        page.click("#home-open-editor")
        page.click("#home-tool-room")
        click_at(page, 9, 1)
        click_at(page, 11, 1)
        page.click("#home-download")
        message = page.locator("#home-message").inner_text()
        assert "Room 3 is not closed" in message, message
        page.keyboard.press("Control+z")
        page.click("#home-undo")
        assert page.locator("#home-problems li.ok").count() == 1
        page.keyboard.press("Control+Shift+z")
        assert "Room 3 is not closed" in page.locator("#home-problems").inner_text()

        # A floor-plan image (400 x 300 px, shown at 1 cm a pixel until scaled): two marks
        # 2 m apart declared 3 m make it 6 m wide.
        image = tmp_path / "plan.png"
        Image.new("RGB", (400, 300), "white").save(image)
        page.set_input_files("#home-image", str(image))
        page.wait_for_selector("#home-background")
        assert page.locator("#home-background").get_attribute("width") == "4"
        click_at(page, 0, 5)
        click_at(page, 2, 5)
        page.fill("#home-known-length", "3")
        page.click("#home-set-scale")
        assert float(page.locator("#home-background").get_attribute("width")) == pytest.approx(
            6, abs=0.05
        )

        # Overlapping furniture is named; undo takes the second table away again.
        page.click("#home-tool-furniture")
        click_at(page, 6.0, 1.8)
        assert "table 2 overlaps table" in page.locator("#home-problems").inner_text()
        page.click("#home-undo")
        assert "overlaps" not in page.locator("#home-problems").inner_text()
        assert not errors, errors
        browser.close()
