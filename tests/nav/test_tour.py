"""A mapping tour of a home for a base that turns on the spot and drives straight
(nav/tour.py): from the dock through every room it can reach and back, each straight leg
and each turn clear for the real footprint; a room behind a doorway narrower than the
base is left out; rooms are visited in the shortest order."""

from __future__ import annotations

import numpy as np

from robotrial.model.gridmap import world_map
from robotrial.model.world import load_world_text
from robotrial.nav.costmap import Costmap, Footprint
from robotrial.nav.hybrid import HybridAStar, footprint_hits
from robotrial.nav.tour import open_spot, room_tour, visit_order
from tests.trials.test_verdict import two_rooms

MOBILE_MANIPULATOR = Footprint(0.99, 0.67)


def tour(doorway: float):
    world = load_world_text(two_rooms(doorway, furniture=True))
    grid = world_map(world)
    origin = np.asarray(grid.origin, dtype=float)
    costmap = Costmap(grid.occupied, tuple(origin), grid.resolution, MOBILE_MANIPULATOR)
    goals = [open_spot(costmap.distance, origin, grid.resolution, r.bounds) for r in world.rooms]
    dock = (1.0, 1.5, 0.0)
    route, visited = room_tour(costmap, dock, goals)
    return world, costmap, dock, route, visited


def test_the_tour_visits_both_rooms_on_straight_legs_clear_for_the_footprint() -> None:
    world, costmap, dock, route, visited = tour(0.9)
    assert sorted(visited) == [0, 1]
    first, second = world.rooms
    assert any(first.contains(x, y) for x, y in route)
    assert any(second.contains(x, y) for x, y in route)
    assert np.hypot(route[-1][0] - dock[0], route[-1][1] - dock[1]) < 0.1  # back at the dock
    assert len(route) < 15  # straight legs, not the planner's points a cell apart
    # drive it as a teleoperator would: turn on the spot, then straight to the next point
    blocked = HybridAStar().blocked(costmap)
    margin = HybridAStar().config.margin
    at, heading = np.array(dock[:2]), dock[2]
    for point in route:
        to = np.asarray(point)
        new = float(np.arctan2(to[1] - at[1], to[0] - at[0]))
        turn = (new - heading + np.pi) % (2 * np.pi) - np.pi
        yaws = heading + np.linspace(0.0, turn, 40)
        spin = np.column_stack([np.full(40, at[0]), np.full(40, at[1]), yaws])
        t = np.linspace(0.0, 1.0, 60)[:, None]
        drive = np.column_stack([at + t * (to - at), np.full(60, new)])
        assert not footprint_hits(costmap, np.vstack([spin, drive]), margin, blocked).any(), (
            f"the leg {at} -> {to} touches an obstacle"
        )
        at, heading = to, new


def test_a_room_behind_a_doorway_narrower_than_the_base_is_left_out() -> None:
    world, _, _, route, visited = tour(0.6)
    assert visited == [0]
    assert not any(world.rooms[1].contains(x, y) for x, y in route)


def test_rooms_are_visited_in_the_shortest_closed_order() -> None:
    # dock at 0, three stops on a line: 1 at 3 m, 2 at 1 m, 3 at 2 m; 4 cut off
    x = np.array([0.0, 3.0, 1.0, 2.0, 9.0])
    d = np.abs(x[:, None] - x[None, :])
    d[4, :] = d[:, 4] = np.inf
    d[4, 4] = 0.0
    assert visit_order(d) in ([2, 3, 1], [1, 3, 2])
