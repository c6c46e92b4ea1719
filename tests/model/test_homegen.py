"""The home generator's extras (model/homegen.py, `HomeSpec.extras`): a side table in
each room with no top at table height and a jar on a top of each room, drawn after the
rest from their own random stream, so every home is the one drawn without them plus
the additions; the additions overlap no furniture, doorway keep-out, dock or object,
and the base still reaches every room."""

from __future__ import annotations

import hashlib
import json
from dataclasses import replace

import numpy as np
import pytest

from robotrial.benchmarks.chores import CHORE_HOMES
from robotrial.model.home import place_in
from robotrial.model.homegen import DOCK_CLEAR, JAR, OBJECT_GAP, SIDE_TABLE, home_plan, home_yaml
from robotrial.model.world import load_world_text
from tests.nav.test_goals import assert_every_room_reached

# The plans as generated before the extras existed (sha256 of the sorted JSON, first 16
# hex digits): the 20 homes of `robotrial bench chores`, and four homes of the default
# spec. A change to any room, doorway, piece, object or dock fails the test.
CHORE_LAYOUTS = {
    3: "dbf74fa004d24d20",
    12: "cb893bb1f08a0a00",
    15: "9202bbc2806f0da9",
    17: "66578728b66d6cbf",
    19: "9ea7cda55bb42143",
    23: "fc12be443f3dbfc4",
    25: "88ffd2105c53f70a",
    28: "ecf9f14029891550",
    31: "5890c2984c2e0737",
    32: "40f20aeda3379a08",
    33: "c16abfde5e1990c5",
    38: "772b42566fdcebac",
    39: "729e1e0edb272985",
    40: "00e46fcd4a04e6ef",
    47: "6a0318e59b2dcb67",
    48: "6ceaa36c4a5f3ac3",
    49: "3f8f897853f5feff",
    52: "5a63b51dd7f1f7b7",
    53: "fd4a4db7a67bec67",
    55: "04b956201a3c5cfb",
}
DEFAULT_LAYOUTS = {
    3: "ecb91c4632ac4e37",
    5: "e6b3a13cc79327a8",
    11: "9c404a20a8b7e1be",
    29: "e69b2bc85957b67c",
}
EXTRA_KINDS = {"furniture": SIDE_TABLE[0], "objects": JAR[0]}


def _layout(plan: dict) -> str:
    return hashlib.sha256(json.dumps(plan, sort_keys=True).encode()).hexdigest()[:16]


def _split(plan: dict) -> tuple[dict, dict[str, list[dict]]]:
    """The plan without its extras, and the extras by group (the extras come last)."""
    bare, extras = dict(plan), {}
    for group, kind in EXTRA_KINDS.items():
        items = plan[group]
        first = next((i for i, it in enumerate(items) if it["name"].startswith(kind)), None)
        first = len(items) if first is None else first
        bare[group], extras[group] = items[:first], items[first:]
        assert all(it["name"].startswith(kind) for it in extras[group]), group
    return bare, extras


def _box(f: dict) -> tuple[float, float, float, float]:
    (x, y), (w, d) = f["at"], f["size"]
    return (x - w / 2, y - d / 2, x + w / 2, y + d / 2)


def _gap(a: tuple, b: tuple) -> float:
    dx = max(a[0] - b[2], b[0] - a[2], 0.0)
    dy = max(a[1] - b[3], b[1] - a[3], 0.0)
    return float(np.hypot(dx, dy))


@pytest.mark.parametrize("seed", sorted(CHORE_LAYOUTS))
def test_the_extras_leave_a_chore_home_as_it_was_drawn(seed) -> None:
    plan = home_plan(seed, spec=CHORE_HOMES)
    bare, extras = _split(plan)
    assert _layout(bare) == CHORE_LAYOUTS[seed]
    assert _layout(home_plan(seed, spec=replace(CHORE_HOMES, extras=False))) == _layout(bare)
    assert extras["objects"], "every chore home gets a jar"


def test_homes_without_extras_are_unchanged() -> None:
    for seed, layout in DEFAULT_LAYOUTS.items():
        plan = home_plan(seed)
        assert _layout(plan) == layout
        assert not _split(plan)[1]["objects"]


@pytest.mark.parametrize("seed", sorted(CHORE_LAYOUTS))
def test_the_added_pieces_overlap_nothing(seed) -> None:
    spec = CHORE_HOMES
    plan = home_plan(seed, spec=spec)
    bare, extras = _split(plan)
    rooms = [(*r["corners"][0], *r["corners"][2]) for r in plan["rooms"]]
    for table in extras["furniture"]:
        box = _box(table)
        (x, y) = table["at"]
        room = next(r for r in rooms if r[0] <= x <= r[2] and r[1] <= y <= r[3])
        assert room[0] < box[0] and box[2] < room[2] and room[1] < box[1] and box[3] < room[3]
        assert not [
            f
            for f in bare["furniture"]
            if room[0] <= f["at"][0] <= room[2] and room[1] <= f["at"][1] <= room[3]
            if 0.4 <= f["height"] <= 1.0
        ], "a side table only where the room has no top"
        for f in plan["furniture"]:
            if f is not table:
                assert _gap(box, _box(f)) >= spec.furniture_gap - 1e-9, (table, f)
        for d in plan["doorways"]:
            # the doorway's swing and the way through it: door_clear deep either side of
            # its wall, 0.35 m wider than the doorway each way
            (dx, dy), reach = d["at"], d["width"] / 2 + 0.35
            along_y = any(abs(dx - r[0]) < 1e-9 or abs(dx - r[2]) < 1e-9 for r in rooms)
            along_y = along_y and not any(
                abs(dy - r[1]) < 1e-9 or abs(dy - r[3]) < 1e-9 for r in rooms
            )
            a, b = (spec.door_clear, reach) if along_y else (reach, spec.door_clear)
            assert _gap(box, (dx - a, dy - b, dx + a, dy + b)) > 0, (table, d)
        spawn = plan["spawn"]
        assert _gap(box, (*spawn, *spawn)) >= DOCK_CLEAR
    for jar in extras["objects"]:
        under = [f for f in plan["furniture"] if _gap(_box(f), (*jar["at"], *jar["at"])) == 0]
        assert len(under) == 1 and 0.4 <= under[0]["height"] <= 1.0
        for other in plan["objects"]:
            if other is not jar:
                assert np.hypot(*np.subtract(jar["at"], other["at"])) >= OBJECT_GAP
        for room in plan["rooms"]:
            place = place_in(plan, room)
            if place is not None:
                assert np.hypot(*np.subtract(jar["at"], place[1])) >= OBJECT_GAP


@pytest.mark.parametrize("seed", [12, 47])
def test_the_base_still_reaches_every_room_of_a_home_with_side_tables(seed) -> None:
    # homes 12 and 47 get two side tables each
    assert len(_split(home_plan(seed, spec=CHORE_HOMES))[1]["furniture"]) == 2
    assert_every_room_reached(load_world_text(home_yaml(seed, spec=CHORE_HOMES)), seed)
