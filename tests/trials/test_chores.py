"""Chores in a buyer's verdict (trials/chores.py): `object:room` read from the command
line, and chores the carry trial cannot do reported with its reason instead of raised.
A chore the trial does run is the carry trial itself (tests/trials/test_carry.py); the
whole verdict with chores is measured by `robotrial bench verdict --chores`."""

from __future__ import annotations

import json

import pytest

from robotrial.cli import main
from robotrial.model import load_world
from robotrial.trials.chores import parse_chore, run_chores


def test_a_chore_is_object_colon_room() -> None:
    assert parse_chore(" cup : bedroom ") == ("cup", "bedroom")
    for bad in ("cup", "cup:", ":bedroom", "cup bedroom"):
        with pytest.raises(ValueError, match="OBJECT:ROOM"):
            parse_chore(bad)


def test_chores_the_trial_cannot_do_are_reported_not_raised() -> None:
    apartment = load_world("apartment")
    told = []
    done = run_chores(
        apartment,
        "mobile_manipulator",
        [("teapot", "bedroom"), ("sofa", "bedroom"), ("cup", "study")],
        seeds=2,
        progress=lambda f, what: told.append(what),
    )
    teapot, sofa, study = done
    assert "no body 'teapot'" in teapot.refused
    assert "furniture, not an object" in sofa.refused
    assert "no place to set things down" in study.refused
    for c in done:
        assert c.runs == 0 and not c.done and c.to_dict()["success_rate"] == 0
    assert told[0] == "chore teapot:bedroom, seed 0"
    (husky,) = run_chores(apartment, "husky", [("cup", "bedroom")])
    assert husky.runs == 0 and husky.refused == (
        "robot 'husky' has no LiDAR to map the home, no arm and no gripper: it cannot do chores"
    )
    with pytest.raises(ValueError, match="at least 1"):
        run_chores(apartment, "mobile_manipulator", [("cup", "bedroom")], seeds=0)


ONE_ROOM = """\
name: one_room
floor: {size: [5.0, 4.0], center: [1.5, 1.5]}
walls:
  - {name: s, from: [-0.1, -0.05], to: [3.1, -0.05]}
  - {name: n, from: [-0.1, 3.05], to: [3.1, 3.05]}
  - {name: w, from: [-0.05, 0.0], to: [-0.05, 3.0]}
  - {name: e, from: [3.05, 0.0], to: [3.05, 3.0]}
rooms:
  - {name: first, min: [0.0, 0.0], max: [3.0, 3.0]}
spawns:
  default: [1.0, 1.5, 0.0]
"""


def test_a_chore_naming_no_object_of_the_home_is_refused_in_the_verdict(tmp_path, capsys) -> None:
    out = tmp_path / "v.json"
    world = tmp_path / "one_room.yaml"
    world.write_text(ONE_ROOM)
    world = str(world)
    assert main(["verdict", "--world", world, "--chore", "x:first", "-o", str(out)]) == 0
    report = json.loads(out.read_text())
    (chore,) = report["chores"]
    assert chore["chore"] == "x:first" and "no body 'x'" in chore["refused"]
    assert report["summary"].endswith("chores: 0 of 1")
    assert main(["verdict", "--world", world, "--chore", "cup"]) == 2
    assert "OBJECT:ROOM" in capsys.readouterr().err
