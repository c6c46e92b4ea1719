"""Goals for any home: the home generator (2-6 rooms, doorways 0.8-1.0 m, furniture, every
room reachable for the base's rectangle), the goal sampler (poses in the free space where
the rectangle fits) and the verdict on a goal before anything drives (off the map, in an
obstacle, too near one, out of the footprint's reach), in words without numpy reprs."""

from __future__ import annotations

import numpy as np
import pytest

from robotrial.model.gridmap import world_map
from robotrial.model.homegen import generate_home, home_plan
from robotrial.model.world import load_world_text
from robotrial.nav.costmap import Costmap, Footprint
from robotrial.nav.goals import GOAL_CLEARANCE, check_goal, sample_goals
from robotrial.nav.profile import rectangle_clearance
from robotrial.trials.nav_goals import draw_goals
from tests.trials.test_verdict import two_rooms

MOBILE_MANIPULATOR = Footprint(0.99, 0.67)


def costmap_of(world) -> Costmap:
    grid = world_map(world)
    return Costmap(grid.occupied, grid.origin, grid.resolution, MOBILE_MANIPULATOR)


@pytest.mark.parametrize("seed", [3, 11, 29])
def test_a_generated_home_has_doorways_furniture_and_every_room_reached(seed) -> None:
    plan = home_plan(seed)
    assert plan == home_plan(seed), "the same seed gives the same home"
    assert 2 <= len(plan["rooms"]) <= 6
    assert len(plan["doorways"]) >= len(plan["rooms"]) - 1
    assert all(0.8 - 1e-9 <= d["width"] <= 1.0 + 1e-9 for d in plan["doorways"])
    assert plan["furniture"]
    assert_every_room_reached(generate_home(seed), seed)


def assert_every_room_reached(world, seed: int) -> None:
    """A goal drawn in every room of `world` is reached by the footprint planner from the
    spawn, on the true map."""
    cm = costmap_of(world)
    spawn = world.spawn("default")
    start = (float(spawn.xyz[0]), float(spawn.xyz[1]), float(spawn.yaw))
    rng = np.random.default_rng(seed)
    for room in world.rooms:
        (x0, y0), (x1, y1) = room.bounds
        (goal,) = sample_goals(cm, 1, rng, region=((x0 + 0.5, y0 + 0.5), (x1 - 0.5, y1 - 0.5)))
        verdict = check_goal(cm, tuple(goal), start)
        assert verdict.kind in ("ok", "here"), (room.name, verdict.reason)


def test_sampled_goals_leave_the_rectangle_room_and_are_judged_reachable() -> None:
    draw = draw_goals("home:5", 6, seed=1)
    assert draw.goals.shape == (6, 3)
    world = generate_home(5)
    cm = costmap_of(world)
    room = rectangle_clearance(cm, draw.goals, cap=GOAL_CLEARANCE)
    assert (room >= GOAL_CLEARANCE - 1e-9).all(), room
    assert len({tuple(np.round(g, 3)) for g in draw.goals}) == 6
    (x0, y0), (x1, y1) = world.interior
    assert all(x0 <= x <= x1 and y0 <= y <= y1 for x, y, _ in draw.goals)


@pytest.mark.parametrize(
    ("goal", "kind", "words"),
    [
        ((40.0, 1.5, 0.0), "off_map", "is off the map, which spans x"),
        ((2.5, -0.05, 0.0), "in_obstacle", "is inside an obstacle"),
        ((2.0, 0.36, 0.0), "too_close", "is too near an obstacle"),
        ((3.72, 0.68, 0.0), "unreachable", "cannot be reached from the start"),
        ((2.0, 1.5, 0.0), "ok", ""),
    ],
    ids=["off-the-map", "in-a-wall", "too-near-a-wall", "behind-a-narrow-doorway", "open"],
)
def test_a_goal_is_judged_in_words_before_driving(goal, kind, words) -> None:
    # two rooms joined by a 0.6 m doorway: the second is out of the 0.67 m base's reach
    cm = costmap_of(load_world_text(two_rooms(0.6, furniture=True)))
    verdict = check_goal(cm, goal, (1.0, 1.5, 0.0))
    assert verdict.kind == kind, verdict.reason
    assert words in verdict.reason
    assert "np." not in verdict.reason and "\n" not in verdict.reason
