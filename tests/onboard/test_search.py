"""Where the search looks for an object (onboard/skills.py): the furniture of a room as
the map shows it, and a free pose facing each piece. The map here is the ground-truth
grid of a generated home (what a finished exploration maps); the search itself runs in
the carry trial (`robotrial bench chores`)."""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from robotrial.benchmarks.chores import chore_homes
from robotrial.model.gridmap import world_map
from robotrial.onboard.catalogue import ObjectKind
from robotrial.onboard.perception import Detection
from robotrial.onboard.skills import (
    LOOK_AT,
    Sighting,
    best_in_room,
    furniture_tops,
    look_pose,
    overlaps,
)
from robotrial.trials.nav_goals import _footprint

MARGIN = _footprint().circumscribed_radius + 0.1


def _home():
    _, world, _ = chore_homes(1)[0]
    grid = world_map(world)
    occupied = np.asarray(grid.occupied, dtype=bool)
    origin = np.asarray(grid.origin, dtype=float)
    clearance = ndimage.distance_transform_edt(~occupied) * grid.resolution
    return world, occupied, origin, grid.resolution, clearance


def test_each_room_s_furniture_is_found_on_the_map_and_its_walls_are_not() -> None:
    world, occupied, origin, res, _ = _home()
    furniture = [o for o in world.obstacles if o.kind == "furniture"]
    for room in world.rooms:
        pieces = furniture_tops(occupied, origin, res, room.bounds)
        inside = [f for f in furniture if room.contains(*f.pose.xyz[:2])]
        assert len(pieces) == len(inside), room.name
        for f in inside:
            nearest = min(np.hypot(*(p.mean(axis=0) - f.pose.xyz[:2])) for p in pieces)
            assert nearest < 0.1, (room.name, f.name)


def test_a_piece_is_looked_at_from_a_free_pose_facing_it() -> None:
    world, occupied, origin, res, clearance = _home()
    looked = 0
    for room in world.rooms:
        for piece in furniture_tops(occupied, origin, res, room.bounds):
            pose = look_pose(piece, clearance, origin, res, room.bounds, MARGIN)
            if pose is None:
                continue
            looked += 1
            assert room.contains(pose[0], pose[1])
            c, r = ((pose[:2] - origin) / res).astype(int)
            assert clearance[r, c] >= MARGIN
            gap = np.min(np.hypot(*(piece - pose[:2]).T))
            assert LOOK_AT[0] - res <= gap <= LOOK_AT[1] + res
            towards = piece.mean(axis=0) - pose[:2]
            assert abs(np.arctan2(towards[1], towards[0]) - pose[2]) < 1e-6
    assert looked >= 2


def test_the_piece_the_order_names_is_told_from_the_others() -> None:
    world, occupied, origin, res, _ = _home()
    furniture = [o for o in world.obstacles if o.kind == "furniture"]
    for room in world.rooms:
        pieces = furniture_tops(occupied, origin, res, room.bounds)
        for f in furniture:
            if not room.contains(*f.pose.xyz[:2]):
                continue
            x, y = f.pose.xyz[:2]
            outline = ((x - 0.05, y - 0.05), (x + 0.05, y + 0.05))
            assert sum(overlaps(p, outline) for p in pieces) == 1, f.name


def test_an_object_of_the_kind_seen_in_another_room_is_not_the_one_sought() -> None:
    can = ObjectKind("can", "box", (0.07, 0.07, 0.07), (0.75, 0.72, 0.68))
    book = ObjectKind("book", "box", (0.06, 0.06, 0.06), (0.75, 0.72, 0.68))

    def seen(kind: ObjectKind, x: float, y: float, error: float) -> Sighting:
        at = (x, y, 0.8)
        return Sighting(
            kind, np.array(at), Detection(kind.name, at, 0.0, 0.07, 0.07, kind.rgb, 50, 0.8, error)
        )

    room = ((0.0, 0.0), (3.0, 3.0))
    through_the_door = seen(can, 4.2, 1.5, 0.1)  # the can's twin, in the next room
    in_the_room = seen(can, 2.5, 1.0, 0.4)
    assert best_in_room([through_the_door, seen(book, 1.0, 1.0, 0.0)], can, room) is None
    assert best_in_room([through_the_door, in_the_room], can, room) is in_the_room
    better = seen(can, 0.5, 2.5, 0.2)
    assert best_in_room([in_the_room, better, through_the_door], can, room) is better
    # a second can, can_2, looks the same: the detector names it "can"
    can_2 = ObjectKind("can_2", "box", (0.07, 0.07, 0.07), (0.75, 0.72, 0.68))
    assert best_in_room([through_the_door, in_the_room], can_2, room) is in_the_room
