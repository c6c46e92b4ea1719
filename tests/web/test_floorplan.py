"""A floor plan from a file, in the page's home editor: a ROS map_server map (a PGM and
its YAML, chosen together) lands at its own scale and origin; Find rooms turns its two
walled rooms and the 0.9 m gap in the wall between them into two rooms and a doorway,
which the downloaded World YAML keeps; a YAML without its image, or with no
resolution, is refused with a message and the drawing stays as it was."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from playwright.sync_api import expect, sync_playwright

from tests.web.home_plan import click_at, download, gaps_on_line_x

pytestmark = [pytest.mark.timeout(120)]

RES = 0.05  # m a pixel
ORIGIN = (-1.0, -0.5)  # where the image's bottom-left corner lies (m)


def two_rooms_pgm(path: Path) -> None:
    """A 10 x 5 m plan: an outer wall (10 cm, dark) around 7.2 x 3.2 m, split at
    x = 4.0-4.1 m (image coordinates) by a wall with a 0.9 m gap."""
    img = np.full((100, 200), 254, dtype=np.uint8)
    img[20:22, 20:166] = img[82:84, 20:166] = 0
    img[20:84, 20:22] = img[20:84, 164:166] = 0
    img[20:40, 100:102] = img[58:84, 100:102] = 0
    path.write_bytes(b"P5\n# two rooms\n200 100\n255\n" + img.tobytes())


@pytest.fixture(scope="module")
def server(serve) -> str:
    return serve()


@pytest.mark.browser
def test_a_map_server_map_becomes_rooms_and_a_doorway(
    server: str, chromium: str, chromium_args: list[str], tmp_path: Path
) -> None:
    pgm = tmp_path / "flat.pgm"
    two_rooms_pgm(pgm)
    yaml = tmp_path / "flat.yaml"
    yaml.write_text(
        f"image: flat.pgm\nresolution: {RES}\norigin: [{ORIGIN[0]}, {ORIGIN[1]}, 0.0]\n"
        "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n"
    )
    broken = tmp_path / "broken.yaml"
    broken.write_text("image: flat.pgm\norigin: [0, 0, 0]\n")
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=chromium_args)
        page = browser.new_page(viewport={"width": 1400, "height": 900}, accept_downloads=True)
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(server)
        page.wait_for_function("window.robotrial && window.robotrial.state().ready")
        page.click("#home-open-editor")

        # The YAML alone, then one without a resolution: refused, nothing drawn.
        page.set_input_files("#home-image", str(yaml))
        message = page.locator("#home-message")
        expect(message).to_contain_text("choose both files together")
        page.set_input_files("#home-image", [str(broken), str(pgm)])
        expect(message).to_contain_text("broken.yaml is not a usable map: its resolution")
        assert page.locator("#home-background").count() == 0
        page.click("#home-find-rooms")
        expect(message).to_contain_text("Load a floor-plan image first")

        # Both files: the image sits at the map's origin, 10 x 5 m.
        page.set_input_files("#home-image", [str(pgm), str(yaml)])
        page.wait_for_selector("#home-background")
        bg = page.locator("#home-background")
        assert float(bg.get_attribute("x")) == pytest.approx(ORIGIN[0])
        assert float(bg.get_attribute("width")) == pytest.approx(10.0)
        assert float(bg.get_attribute("height")) == pytest.approx(5.0)
        expect(message).to_contain_text("1 pixel is 5.00 cm")

        page.click("#home-find-rooms")
        expect(message).to_contain_text("Found 2 rooms and 1 doorway")
        page.click("#home-tool-spawn")
        click_at(page, 1.0, 1.5)
        world = download(page, tmp_path / "home.yaml")
        browser.close()
    assert not errors, errors
    # The middle wall: image x 100-102 px, its middle line at 5.05 m from the image's
    # left edge; the gap 18 px = 0.9 m.
    assert len(world.rooms) == 2
    assert gaps_on_line_x(world, ORIGIN[0] + 5.05) == [pytest.approx(0.9, abs=1e-6)]
