"""The poses a rectangular base reaches from a start (nav/reachable.py): a doorway
narrower than the base closes the room behind it, a wider one opens it."""

from __future__ import annotations

import numpy as np

from robotrial.model.gridmap import world_map
from robotrial.model.world import load_world_text
from robotrial.nav.costmap import Costmap, Footprint
from robotrial.nav.reachable import reachable_poses

HUSKY = Footprint(0.99, 0.67)


def home(doorway: float) -> str:
    half = doorway / 2
    return f"""\
name: doorway
floor: {{size: [8.0, 5.0], center: [3.0, 1.5]}}
walls:
  - {{name: s, from: [-0.1, -0.05], to: [6.1, -0.05]}}
  - {{name: n, from: [-0.1, 3.05], to: [6.1, 3.05]}}
  - {{name: w, from: [-0.05, 0.0], to: [-0.05, 3.0]}}
  - {{name: e, from: [6.05, 0.0], to: [6.05, 3.0]}}
  - {{name: low, from: [3.0, 0.0], to: [3.0, {1.5 - half}]}}
  - {{name: high, from: [3.0, {1.5 + half}], to: [3.0, 3.0]}}
"""


def poses_in_second_room(doorway: float) -> np.ndarray:
    grid = world_map(load_world_text(home(doorway)))
    costmap = Costmap(grid.occupied, tuple(grid.origin), grid.resolution, HUSKY)
    found = reachable_poses(costmap, (1.0, 1.5, 0.0))
    probe = np.array([[4.5, 1.5, 0.0], [4.5, 1.5, np.pi / 2], [1.5, 1.5, 1.0]])
    assert found.contains(probe[2:]).all()  # the start's own room
    assert found.clear(probe).all()  # open floor in both rooms
    return found.contains(probe[:2])


def test_a_narrow_doorway_closes_the_room_behind_it() -> None:
    assert not poses_in_second_room(0.6).any()
    assert poses_in_second_room(0.9).all()
