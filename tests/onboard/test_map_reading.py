"""The map the navigation plans on after exploring (onboard/explore.py): SLAM's map read
as the explorer read it, so the way the robot explored stays open to the footprint
planner."""

from __future__ import annotations

import numpy as np

from robotrial.benchmarks.chores import chore_homes
from robotrial.model.gridmap import world_map
from robotrial.nav.costmap import Costmap
from robotrial.nav.goals import check_goal, sample_goals
from robotrial.onboard.explore import navigation_values
from robotrial.trials.nav_goals import _footprint


def test_floor_few_nodes_saw_stays_open_to_the_navigation_after_exploring() -> None:
    """A generated home mapped as the pose graph maps it when few of its nodes saw the
    floor: free cells at probability 0.4, walls and furniture at 0.9. The explorer drove
    there (it takes cells up to 0.45 as free); the navigation after it reaches every room
    on that map, where a map's usual 0.35 threshold leaves the floor unknown."""
    _, world, _ = chore_homes(1)[0]
    grid = world_map(world)
    p = np.where(grid.occupied, 0.9, 0.4)
    fp = _footprint()

    def costmap(values: np.ndarray) -> Costmap:
        # as the navigation node reads the map it is given
        return Costmap(values >= 65, grid.origin, grid.resolution, fp, unknown=values < 0)

    explored = costmap(navigation_values(p))
    usual = costmap(np.where(p >= 0.65, 100, np.where(p <= 0.35, 0, -1)).astype(np.int8))
    spawn = world.spawn("default")
    start = (float(spawn.xyz[0]), float(spawn.xyz[1]), float(spawn.yaw))
    rng = np.random.default_rng(0)
    for room in world.rooms:
        (x0, y0), (x1, y1) = room.bounds
        (goal,) = sample_goals(
            explored, 1, rng, region=((x0 + 0.5, y0 + 0.5), (x1 - 0.5, y1 - 0.5))
        )
        verdict = check_goal(explored, tuple(goal), start)
        assert verdict.kind in ("ok", "here"), (room.name, verdict.reason)
        assert not check_goal(usual, tuple(goal), start).ok
