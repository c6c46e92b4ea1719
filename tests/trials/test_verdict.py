"""The base part of a buyer's verdict: a home drawn as a World YAML, a 0.6 m doorway the
0.67 m wide mobile manipulator cannot pass and a 0.9 m one it can; the apartment, whose
rooms Hybrid-A* reaches with the real footprint (docs/worlds.md); the CLI's files."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from robotrial.cli import main
from robotrial.model import load_world
from robotrial.nav.costmap import Footprint
from robotrial.trials.verdict import check_base

MOBILE_MANIPULATOR = Footprint(0.99, 0.67)


def two_rooms(doorway: float) -> str:
    """Two 3 x 3 m rooms side by side; the shared wall has a doorway `doorway` m wide."""
    half = doorway / 2
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
"""


def home(tmp_path: Path, doorway: float) -> Path:
    path = tmp_path / f"home_{doorway}.yaml"
    path.write_text(two_rooms(doorway))
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
    assert [r["colour"] for r in report["rooms"]] == ["green", "red"]
    text = page.read_text()
    assert "fits: 1 of 2 rooms" in text and "data:image/png;base64," in text


def test_a_world_without_rooms_or_file_is_a_clear_error(tmp_path, capsys) -> None:
    bare = tmp_path / "bare.yaml"
    bare.write_text(two_rooms(0.9).split("rooms:")[0] + "spawns:\n  default: [1.0, 1.5, 0.0]\n")
    with pytest.raises(ValueError, match="names no rooms"):
        check_base(load_world(bare), MOBILE_MANIPULATOR)
    assert main(["verdict", "--world", str(tmp_path / "missing.yaml")]) == 2
    assert "missing.yaml" in capsys.readouterr().err
