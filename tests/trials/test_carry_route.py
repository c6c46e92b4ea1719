"""The carry trial in a home without a hand-drawn mapping route (a home drawn in the
page, a World YAML), asked to map along a route (`mapping='route'`; by default such a
home is explored by frontiers): the trial makes its own tour of the rooms (nav/tour.py)
and maps the home along it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from robotrial.model import load_world
from robotrial.trials.carry import CarrySetup, exploration_route, run_carry
from robotrial.trials.nav import footprint_of_robot
from tests.trials.test_verdict import two_rooms

TABLES = """\
  - {name: side_table, kind: furniture, shape: box, size: [0.8, 0.6, 0.6],
     pose: {xyz: [4.5, 2.68, 0.3]}}
objects:
  - {name: cup, shape: cylinder, radius: 0.03, length: 0.1, mass: 0.15,
     pose: {xyz: [1.4, 2.55, 0.65]}}
"""


def home(tmp_path: Path) -> Path:
    """The two 3 x 3 m rooms with a 0.9 m doorway: a table in the first with the cup on
    it, a side table in the second where things are set down."""
    text = two_rooms(0.9).replace(
        "  - {name: second, min: [3.05, 0.0], max: [6.0, 3.0]}",
        "  - {name: second, min: [3.05, 0.0], max: [6.0, 3.0],\n"
        "     place: {surface: side_table, xy: [4.5, 2.55]}}",
    )
    text += (
        "obstacles:\n  - {name: table, kind: furniture, shape: box, size: [1.0, 0.6, 0.6], "
        "pose: {xyz: [1.5, 2.68, 0.3]}}\n" + TABLES
    )
    path = tmp_path / "two_rooms.yaml"
    path.write_text(text)
    return path


def test_a_home_without_a_route_gets_one_through_both_rooms(tmp_path: Path) -> None:
    world = load_world(home(tmp_path))
    route = exploration_route(world, footprint_of_robot("mobile_manipulator", world))
    first, second = world.rooms
    assert any(first.contains(x, y) for x, y in route[:-1])
    assert any(second.contains(x, y) for x, y in route)
    assert route[-1] == pytest.approx((1.0, 1.5), abs=0.1)  # back at the dock
    with pytest.raises(ValueError, match="'room_a' names no rooms, so no mapping route"):
        exploration_route(load_world("room_a"), footprint_of_robot("mobile_manipulator"))


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_the_made_tour_maps_both_rooms_of_a_home_drawn_without_a_route(tmp_path: Path) -> None:
    """The robot drives the made tour with SLAM and ends the mapping phase with a map of
    both rooms: most of each room's floor free on its map, the table seen, and its pose
    on that map with the truth. (The rest of the trial is the carry trial's test.)"""
    world = load_world(home(tmp_path))
    setup = CarrySetup(world=world, object="cup", to="second", mapping="route")
    r = run_carry(setup, 0, until="search")
    assert r.stopped == "search" and not r.cause, (r.failed_phase, r.cause, r.reason)
    assert [p["phase"] for p in r.phases] == ["mapping"]
    assert r.map_image is not None
    sx, sy, syaw = r.map_in_world
    res, (ox, oy) = r.map_resolution, r.map_origin

    def cells(x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
        """The map's cells over a world rectangle (the map frame is the spawn's)."""
        c0, r0 = int((x0 - sx - ox) / res), int((y0 - sy - oy) / res)
        c1, r1 = int((x1 - sx - ox) / res), int((y1 - sy - oy) / res)
        return r.map_image[r0:r1, c0:c1]

    assert syaw == 0.0
    for room in world.rooms:
        (x0, y0), (x1, y1) = room.bounds
        inner = cells(x0 + 0.3, y0 + 0.3, x1 - 0.3, y1 - 0.3)
        assert (inner == 0).mean() > 0.6, (room.name, (inner == 0).mean())
    table = cells(1.05, 2.4, 1.95, 2.95)  # the table in the first room: its front edge
    assert (table == 100).any()
    gap = np.hypot(r.estimate[-1, 1] + sx - r.truth[-1, 1], r.estimate[-1, 2] + sy - r.truth[-1, 2])
    assert gap < 0.1
