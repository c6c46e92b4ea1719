"""Frontiers on a hand-made grid: a known room whose doorway opens on an unknown one."""

from __future__ import annotations

import numpy as np

from robotrial.nav.costmap import Footprint
from robotrial.nav.frontier import FrontierPlanner, find_frontiers

RES = 0.05
FOOTPRINT = Footprint(0.99, 0.67)


def two_rooms() -> tuple[np.ndarray, np.ndarray]:
    """An 8 x 4 m grid: walls round it and across x = 4 m with a 1 m doorway (y 1.5-2.5);
    the left room and the doorway's first cells known free, the right room unknown."""
    occupied = np.zeros((80, 160), dtype=bool)
    occupied[0, :] = occupied[-1, :] = occupied[:, 0] = occupied[:, -1] = True
    occupied[:, 80] = True
    occupied[30:50, 80] = False
    free = np.zeros_like(occupied)
    free[1:-1, 1:80] = True
    free[30:50, 80:83] = True
    return occupied, free & ~occupied


def test_the_frontier_is_the_doorway_into_the_unknown_room() -> None:
    occupied, free = two_rooms()
    groups = find_frontiers(free, ~(occupied | free), (0.0, 0.0), RES)
    assert len(groups) == 1
    (f,) = groups
    assert abs(f.centre[0] - 4.125) < 0.05 and abs(f.centre[1] - 2.0) < 0.05
    assert 1.0 <= f.size < 1.2  # the doorway's 20 cells and the jambs' ends


def test_the_goal_looks_through_the_doorway_from_a_clear_pose_on_the_known_side() -> None:
    occupied, free = two_rooms()
    planner = FrontierPlanner(FOOTPRINT)
    choices = planner.choose(occupied, free, (0.0, 0.0), RES, np.array([1.0, 1.0, 0.0]))
    assert choices
    best = choices[0]
    x, y, yaw = best.goal
    assert x < 4.0 and 1.0 < y < 3.0  # in the known room, before the doorway
    assert abs(np.cos(yaw)) > 0.7 and np.cos(yaw) > 0  # facing the doorway (+x)
    assert best.gain > 2.0  # the cone of the unknown room seen through the doorway
    cm = planner.costmap(occupied, ~(occupied | free), (0.0, 0.0), RES)
    assert not planner.planner.collides(cm, best.goal[None, :])[0]


def test_a_blacklisted_place_is_not_chosen_again_and_a_known_home_has_no_goal() -> None:
    occupied, free = two_rooms()
    planner = FrontierPlanner(FOOTPRINT)
    pose = np.array([1.0, 1.0, 0.0])
    first = planner.choose(occupied, free, (0.0, 0.0), RES, pose)
    for c in first:
        planner.blacklist(c.goal[:2])
    again = planner.choose(occupied, free, (0.0, 0.0), RES, pose)
    for c in again:
        assert min(np.hypot(*(c.goal[:2] - b)) for b in planner.blacklisted) >= 0.4
    known = ~occupied
    assert planner.choose(occupied, known, (0.0, 0.0), RES, pose) == []
