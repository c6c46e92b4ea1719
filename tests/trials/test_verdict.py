"""A buyer's verdict: a home drawn as a World YAML, a 0.6 m doorway the 0.67 m wide
mobile manipulator cannot pass and a 0.9 m one it can; the apartment, whose rooms
Hybrid-A* reaches with the real footprint (docs/worlds.md); what the arm reaches on the
furniture; robots without an arm or without a base; two robots side by side; the CLI's
files."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from robotrial.cli import main
from robotrial.model import load_world
from robotrial.nav.costmap import Footprint
from robotrial.trials.reach import NO_ARM
from robotrial.trials.verdict import (
    VerdictError,
    check_base,
    check_home,
    compare,
    drive_to_rooms,
    pictures,
    write_page,
)

MOBILE_MANIPULATOR = Footprint(0.99, 0.67)


FURNITURE = """\
obstacles:
  - {name: table, kind: furniture, shape: box, size: [1.0, 0.6, 0.6], pose: {xyz: [1.5, 2.68, 0.3]}}
  - {name: cupboard, kind: furniture, shape: box, size: [0.6, 0.4, 1.9],
     pose: {xyz: [0.4, 0.3, 0.95]}}
  - {name: far_table, kind: furniture, shape: cylinder, radius: 0.4, length: 0.6,
     pose: {xyz: [4.5, 1.5, 0.3]}}
"""


def two_rooms(doorway: float, furniture: bool = False) -> str:
    """Two 3 x 3 m rooms side by side; the shared wall has a doorway `doorway` m wide;
    with `furniture`, a low table against the first room's north wall, a tall cupboard
    in its south-west corner and a round table in the middle of the second room."""
    half = doorway / 2
    extra = FURNITURE if furniture else ""
    return f"""\
name: two_rooms
floor: {{size: [8.0, 5.0], center: [3.0, 1.5], height: 0.0}}
wall_defaults: {{thickness: 0.1, height: 1.0}}
walls:
  - {{name: south, from: [-0.1, -0.05], to: [6.1, -0.05]}}
  - {{name: north, from: [-0.1, 3.05], to: [6.1, 3.05]}}
  - {{name: west, from: [-0.05, 0.0], to: [-0.05, 3.0]}}
  - {{name: east, from: [6.05, 0.0], to: [6.05, 3.0]}}
  - {{name: shared_low, from: [3.0, 0.0], to: [3.0, {1.5 - half}]}}
  - {{name: shared_high, from: [3.0, {1.5 + half}], to: [3.0, 3.0]}}
rooms:
  - {{name: first, min: [0.0, 0.0], max: [2.95, 3.0]}}
  - {{name: second, min: [3.05, 0.0], max: [6.0, 3.0]}}
spawns:
  default: [1.0, 1.5, 0.0]
{extra}"""


def home(tmp_path: Path, doorway: float, furniture: bool = False) -> Path:
    path = tmp_path / f"home_{doorway}{'_furnished' if furniture else ''}.yaml"
    path.write_text(two_rooms(doorway, furniture))
    return path


def test_a_doorway_narrower_than_the_base_leaves_the_second_room_unreachable(tmp_path) -> None:
    narrow = check_base(load_world(home(tmp_path, 0.6)), MOBILE_MANIPULATOR)
    first, second = narrow.rooms
    assert first.reachable and not second.reachable and second.colour == "red"
    assert "1 of 2 rooms" in narrow.summary and "second" in narrow.summary
    wide = check_base(load_world(home(tmp_path, 0.9)), MOBILE_MANIPULATOR)
    second = wide.rooms[1]
    assert second.reachable and second.colour == "amber"  # passes, cannot turn in the door
    assert 0.67 < second.passage < 1.0
    assert "2 of 2 rooms" in wide.summary


@pytest.mark.parametrize("doorway", [0.6, 0.9])
def test_driving_agrees_with_the_verdict_in_the_two_room_home(tmp_path, doorway) -> None:
    """The navigation trial (AMCL in MuJoCo, Hybrid-A*, the speed profile) from the dock to
    each room's goal gets where the verdict says the base gets, and not elsewhere.
    `robotrial bench verdict` does the same in the apartment."""
    world = load_world(home(tmp_path, doorway))
    verdict = check_base(world, MOBILE_MANIPULATOR)
    rows = drive_to_rooms(verdict, world, "mobile_manipulator")
    assert [r["driven"] for r in rows] == [True, doorway > 0.67], rows
    assert all(r["agrees"] for r in rows)


def test_every_apartment_room_is_reachable_for_the_footprint() -> None:
    verdict = check_base(load_world("apartment"), MOBILE_MANIPULATOR)
    assert {r.room for r in verdict.rooms if r.reachable} == {
        "living_room",
        "kitchen",
        "corridor",
        "bedroom",
        "study",
    }
    study = next(r for r in verdict.rooms if r.room == "study")
    assert study.colour == "amber"  # docs/worlds.md: the base turns with its front in the door


def test_cli_writes_json_and_a_page(tmp_path, capsys) -> None:
    out, page = tmp_path / "v.json", tmp_path / "v.html"
    code = main(
        ["verdict", "--world", str(home(tmp_path, 0.6)), "-o", str(out), "--html", str(page)]
    )
    assert code == 0
    report = json.loads(out.read_text())
    assert report["summary"].startswith("fits: 1 of 2 rooms")
    assert [r["colour"] for r in report["base"]["rooms"]] == ["green", "red"]
    text = page.read_text()
    assert "fits: 1 of 2 rooms" in text and "data:image/png;base64," in text


def test_a_world_without_rooms_or_file_is_a_clear_error(tmp_path, capsys) -> None:
    bare = tmp_path / "bare.yaml"
    bare.write_text(two_rooms(0.9).split("rooms:")[0] + "spawns:\n  default: [1.0, 1.5, 0.0]\n")
    with pytest.raises(ValueError, match="names no rooms"):
        check_base(load_world(bare), MOBILE_MANIPULATOR)
    assert main(["verdict", "--world", str(tmp_path / "missing.yaml")]) == 2
    assert "missing.yaml" in capsys.readouterr().err


@pytest.fixture(scope="module")
def furnished(tmp_path_factory: pytest.TempPathFactory):
    """The mobile manipulator's verdict in the furnished home behind a 0.6 m doorway,
    with the progress it reported."""
    told: list[tuple[float, str]] = []
    path = home(tmp_path_factory.mktemp("home"), 0.6, furniture=True)
    verdict = check_home(
        load_world(path), "mobile_manipulator", progress=lambda f, w: told.append((f, w))
    )
    return verdict, told


def test_the_hand_reaches_the_low_table_not_the_cupboard_top_nor_the_closed_room(
    furnished,
) -> None:
    verdict, _ = furnished
    reach = {s.surface: s for s in verdict.reach.surfaces}
    table, cupboard, far = reach["table"], reach["cupboard"], reach["far_table"]
    # the table stands against the wall: the base parks on three sides, the hand gets
    # to the edges, not to the middle of the back against the wall
    assert 0.05 < table.share < 0.9 and table.parked > 0
    x, y = table.points.T
    back = (y > 2.8) & (np.abs(x - 1.5) < 0.3)
    front = y < 2.45
    assert table.heat[back].max() == 0 and table.heat[front].min() > 0
    # 1.9 m is above the hand; the round table is in the room the base cannot enter
    assert cupboard.share == 0 and cupboard.verdict == "no" and cupboard.parked > 0
    assert "out of the arm's reach" in cupboard.reason
    assert far.share == 0 and far.parked == 0 and "from the dock" in far.reason
    lo, hi = verdict.reach.heights.span
    assert 0.0 < lo < 0.7 < hi < 1.9
    assert verdict.summary.startswith("fits: 1 of 2 rooms (not second); reaches: table")
    assert "cupboard, far_table no" in verdict.summary


def test_progress_runs_from_zero_to_one_and_the_figures_are_json(furnished) -> None:
    verdict, told = furnished
    fractions = [f for f, _ in told]
    assert fractions[0] == 0.0 and fractions[-1] == 1.0
    assert fractions == sorted(fractions)
    assert any("reach: table" in w for _, w in told)
    report = json.loads(json.dumps(verdict.to_dict()))
    assert report["summary"] == verdict.summary and report["chores"] is None
    assert [r["colour"] for r in report["base"]["rooms"]] == ["green", "red"]
    table = next(s for s in report["reach"]["surfaces"] if s["surface"] == "table")
    assert len(table["heat_map"]["xy"]) == len(table["heat_map"]["poses"]) == 12 * 20


def test_a_robot_without_an_arm_gets_rooms_but_no_reach(tmp_path) -> None:
    verdict = check_home(load_world(home(tmp_path, 0.9, furniture=True)), "husky")
    assert not verdict.reach.checked and verdict.reach.reason == NO_ARM
    assert verdict.summary == f"fits: 2 of 2 rooms; {NO_ARM}"
    assert json.loads(json.dumps(verdict.to_dict()))["reach"]["surfaces"] == []


def test_a_dock_the_base_does_not_fit_leaves_every_room_red_and_reach_unchecked(tmp_path) -> None:
    path = tmp_path / "tight_dock.yaml"
    path.write_text(
        two_rooms(0.9, furniture=True).replace("default: [1.0, 1.5", "default: [0.2, 1.5")
    )
    verdict = check_home(load_world(path), "mobile_manipulator")
    assert [r.colour for r in verdict.base.rooms] == ["red", "red"]
    assert not verdict.reach.checked and "at the dock" in verdict.reach.reason
    assert verdict.summary.startswith("fits: 0 of 2 rooms (not first, second); reach not checked")


def test_a_robot_without_a_base_is_refused_by_name(tmp_path, capsys) -> None:
    with pytest.raises(VerdictError, match="'manipulator_h' has no mobile base"):
        check_home(load_world(home(tmp_path, 0.9)), "manipulator_h")
    assert main(["verdict", "--world", str(home(tmp_path, 0.9)), "--robot", "desk_arm"]) == 2
    assert "'desk_arm' has no mobile base" in capsys.readouterr().err.replace("\n", " ")


def test_two_robots_side_by_side_mark_where_they_differ(furnished, tmp_path) -> None:
    verdict, _ = furnished
    husky = check_home(verdict.home, "husky")
    table = compare([verdict, husky])
    assert table["robots"] == ["mobile_manipulator", "husky"]
    rows = {(r["part"], r["item"]): r for r in table["rows"]}
    assert not rows[("rooms", "second")]["differ"]  # both too wide for the doorway
    assert rows[("reach", "table")]["differ"]
    assert rows[("reach", "table")]["values"][1] == NO_ARM
    assert len(table["verdicts"]) == 2
    drawn, plain = pictures(verdict), pictures(husky)
    assert set(drawn) == {"floor_plan", "reach", "heights"} and set(plain) == {"floor_plan"}
    assert all(png[:4] == b"\x89PNG" for png in [*drawn.values(), *plain.values()])
    pdf, png = (
        write_page([verdict, husky], tmp_path / "v.pdf"),
        write_page(verdict, tmp_path / "v.png"),
    )
    assert pdf.read_bytes()[:4] == b"%PDF" and png.read_bytes()[:4] == b"\x89PNG"
    with pytest.raises(ValueError, match=r"\.pdf or \.png"):
        write_page(verdict, tmp_path / "v.svg")


def test_cli_judges_two_robots_in_one_view(tmp_path, capsys) -> None:
    out, page = tmp_path / "both.json", tmp_path / "both.html"
    world = str(home(tmp_path, 0.9, furniture=True))
    args = ["verdict", "--world", world, "--robot", "mobile_manipulator", "--robot", "husky"]
    assert (
        main([*args, "-o", str(out), "--html", str(page), "--page", str(tmp_path / "p.pdf")]) == 0
    )
    report = json.loads(out.read_text())
    assert report["robots"] == ["mobile_manipulator", "husky"]
    assert [v["robot"] for v in report["verdicts"]] == report["robots"]
    differ = {r["item"] for r in report["rows"] if r["differ"]}
    assert {"table", "cupboard"} <= differ and "second" not in differ
    text = page.read_text()
    assert text.count("<div class=col>") == 2 and "<tr class=differ><th>table</th>" in text
    assert (tmp_path / "p.pdf").read_bytes()[:4] == b"%PDF"
    printed = "".join(capsys.readouterr()).replace("\n", " ")
    assert "mobile_manipulator: fits: 2 of 2 rooms" in printed and "husky: fits" in printed
    assert main([*args, "--robot", "desk_arm"]) == 2
