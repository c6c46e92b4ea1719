"""Helpers for browser tests of the home editor: clicks on its plan in metres, and what
a downloaded home holds."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
from playwright.sync_api import Page

from robotrial.model import load_world
from robotrial.model.world import World


def click_at(page: Page, x: float, y: float) -> None:
    """Click the plan at (x, y) metres."""
    point = page.evaluate(
        """([x, y]) => {
            const ctm = document.getElementById('home-plan').getScreenCTM();
            const p = new DOMPoint(x, y).matrixTransform(ctm);
            return [p.x, p.y];
        }""",
        [x, y],
    )
    page.mouse.click(point[0], point[1])


def draw_room(page: Page, corners: list[tuple[float, float]]) -> None:
    for x, y in [*corners, corners[0]]:
        click_at(page, x, y)


def gaps_on_line_x(world: World, x: float) -> list[float]:
    """The gaps between the walls that run along x = `x` (north-south)."""
    spans = []
    for wall in world.walls:
        centre = np.asarray(wall.pose.xyz)
        length = wall.geometry.size[0]
        along_y = abs(abs(wall.pose.yaw) - np.pi / 2) < 1e-6
        if along_y and abs(centre[0] - x) < 1e-6:
            spans.append((centre[1] - length / 2, centre[1] + length / 2))
    spans.sort()
    return [round(b[0] - a[1], 3) for a, b in itertools.pairwise(spans)]


def download(page: Page, path: Path) -> World:
    with page.expect_download() as info:
        page.click("#home-download")
    info.value.save_as(path)
    return load_world(path)
