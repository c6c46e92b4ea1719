"""Chores in a buyer's verdict (trials/chores.py): `object:room` read from the command
line, chores the carry trial cannot do reported with its reason instead of raised, the
homes and chores of `robotrial bench chores`, a chore's time by what it was spent on,
and which homes the robot explores on its own.
A chore the trial does run is the carry trial itself (tests/trials/test_carry.py); the
whole verdict with chores is measured by `robotrial bench verdict --chores`."""

from __future__ import annotations

import json

import numpy as np
import pytest

from robotrial.cli import main
from robotrial.model import load_world
from robotrial.trials.carry import CarrySetup, run_carry
from robotrial.trials.chores import parse_chore, run_chores, split_object, time_shares


def test_a_chore_is_object_colon_room() -> None:
    assert parse_chore(" cup : bedroom ") == ("cup", "bedroom")
    for bad in ("cup", "cup:", ":bedroom", "cup bedroom"):
        with pytest.raises(ValueError, match="OBJECT:ROOM"):
            parse_chore(bad)


def test_a_chore_may_name_the_furniture_the_object_is_on() -> None:
    obj, room = parse_chore("cup@kitchen_table:bedroom")
    assert (split_object(obj), room) == (("cup", "kitchen_table"), "bedroom")
    assert split_object("cup") == ("cup", "")
    for bad in ("cup@:bedroom", "@table:bedroom"):
        with pytest.raises(ValueError, match="cup@kitchen_table:bedroom"):
            parse_chore(bad)
    with pytest.raises(ValueError, match="'cup' is not furniture"):
        run_carry(CarrySetup(on="cup"), 0)  # an object, not furniture


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


def test_chore_homes_have_small_rooms_a_dock_anywhere_and_chores_between_rooms() -> None:
    from robotrial.benchmarks.chores import chore_homes
    from robotrial.model.homegen import DOCK_CLEAR

    homes = chore_homes(3)
    docks = set()
    for seed, world, chores in homes:
        for room in world.rooms:
            (x0, y0), (x1, y1) = room.bounds
            assert min(x1 - x0, y1 - y0) >= 2.7 - 1e-9, (seed, room.name)
        x, y = world.spawn("default").xyz[:2]
        assert any(r.contains(x, y) for r in world.rooms)
        for f in world.obstacles:
            if f.kind == "furniture":
                fx, fy = f.pose.xyz[:2]
                assert np.hypot(x - fx, y - fy) >= DOCK_CLEAR, (seed, f.name)
        docks.add(next(r.name for r in world.rooms if r.contains(x, y)))
        assert 1 <= len(chores) <= 3
        for obj, to in chores:
            ob = world.body(obj)
            here = next(r for r in world.rooms if r.contains(*ob.pose.xyz[:2]))
            assert here.name != to and world.room(to).place is not None
    assert len(docks) > 1  # not always the first room


def test_an_object_whose_twin_stands_in_another_room_gets_chores_after_the_others() -> None:
    from robotrial.benchmarks.chores import chore_homes

    # home 25: a can and a book in Room 1, the book's twin (book_2) in Room 3
    ((seed, world, chores),) = chore_homes(1, first=25)
    assert seed == 25
    assert chores == [("can", "Room 3"), ("book", "Room 3"), ("book_2", "Room 1")]
    rooms = {
        o.name: next(r.name for r in world.rooms if r.contains(*o.pose.xyz[:2]))
        for o in world.objects
    }
    assert rooms["book"] != rooms["book_2"]


def test_each_of_the_twenty_chore_homes_offers_three_chores_its_first_ones_kept() -> None:
    from dataclasses import replace

    from robotrial.benchmarks.chores import (
        CHORE_HOMES,
        ROBOT,
        _offered,
        chore_homes,
        gripper_opening,
    )
    from robotrial.model.homegen import generate_home

    grip = gripper_opening(ROBOT)
    homes = chore_homes(20, grip=grip)
    assert [seed for seed, _, _ in homes] == [
        3, 12, 15, 17, 19, 23, 25, 28, 31, 32, 33, 38, 39, 40, 47, 48, 49, 52, 53, 55
    ]  # fmt: skip
    assert all(len(chores) == 3 for _, _, chores in homes)
    bare = replace(CHORE_HOMES, extras=False)
    kept = 0
    for seed, world, chores in homes:
        alone, apart = _offered(generate_home(seed, spec=bare), grip)
        before = (alone + apart)[:3]
        assert chores[: len(before)] == before, seed  # the chores measured before the extras
        kept += len(before)
        assert all(world.room(to).place is not None for _, to in chores)
    assert kept == 37


def test_a_run_split_from_its_kth_chore_runs_each_home_s_later_chores_only(capsys) -> None:
    from robotrial.benchmarks.chores import chore_jobs

    homes = [(1, "w1", [("a", "R1")]), (2, "w2", [("b", "R2"), ("c", "R1"), ("d", "R3")])]
    homes.append((3, "w3", [("e", "R1"), ("f", "R2")]))
    every = [(s, c, k) for s, _, c, k in chore_jobs(homes)]
    assert every == [
        (1, ("a", "R1"), 1),
        (2, ("b", "R2"), 1),
        (3, ("e", "R1"), 1),
        (2, ("c", "R1"), 2),
        (3, ("f", "R2"), 2),
        (2, ("d", "R3"), 3),
    ]
    assert [(s, k) for s, _, _, k in chore_jobs(homes, 2)] == [(2, 2), (3, 2), (2, 3)]
    assert [(s, k) for s, _, _, k in chore_jobs(homes, 4)] == []
    with pytest.raises(SystemExit, match="--from-chore must be 1 to --chores"):
        main(["bench", "chores", "--chores", "2", "--from-chore", "3"])


def test_a_chores_time_is_split_into_exploring_navigating_searching_manipulating() -> None:
    phases = [
        {"phase": "mapping", "start": 0.0, "time": 60.0},
        {"phase": "search", "start": 60.0, "time": 10.0},
        {"phase": "navigation", "start": 70.0, "time": 20.0},
        {"phase": "pick", "start": 90.0, "time": 15.0},
        {"phase": "carry", "start": 105.0, "time": 25.0},
        {"phase": "place", "start": 130.0, "time": 5.0},
    ]
    assert time_shares(phases) == {
        "exploring": 60.0,
        "navigating": 45.0,
        "searching": 10.0,
        "manipulating": 20.0,
    }
    assert sum(time_shares(phases[:2]).values()) == 70.0  # a run that stopped in search


def test_a_home_without_a_route_is_explored_and_the_apartment_keeps_its_route() -> None:
    from robotrial.trials.carry import ROUTES, CarrySetup, mapping_route
    from robotrial.trials.nav_goals import _footprint, named_world

    home = named_world("home:1:2")
    apartment = load_world("apartment")
    fp = _footprint()
    assert mapping_route(CarrySetup(world=home), home, fp) == []
    assert mapping_route(CarrySetup(), apartment, fp) == ROUTES["apartment"]
    assert mapping_route(CarrySetup(mapping="frontier"), apartment, fp) == []
    assert len(mapping_route(CarrySetup(world=home, mapping="route"), home, fp)) >= 2
