"""`robotrial bench chores`: chores in generated homes, mapped by exploration (layer 5).

Homes from the home generator with rooms of about 3 x 3 m (`CHORE_HOMES`: 2-4 rooms of
8.5-9.5 m2, no side under 2.7 m), furniture along the walls, an object on every table,
the robot's dock at a free spot of a random room, and the extras (`HomeSpec.extras`: a
side table in each room with no top, a 5 cm jar on a top of each room). The homes are
the first `--homes` seeds from `--first-home` on that offer, as drawn without the
extras, a chore (`trials.chores.home_chores`: an object to another room with a place,
the object one the robot's gripper closes across: the generator's 8 cm cups are as wide
as the mobile manipulator's gripper opens, so only its books, cans and jars are carried;
nor an object with a twin of the same shape, size and colour in its own room, which the
camera cannot tell apart: the search looks only in the object's room, so a twin in
another room is no confusion; a home is taken for a chore of an object with no twin at
all, and chores of objects with twins in other rooms come after its others); each gets
up to `--chores` chores, those it offered without the extras first, then those the
extras add (rooms with a side table to carry to, jars to carry), so the homes and the
chores measured before the extras keep their numbers (every home's first chore runs
before any home's second; `--from-chore K` runs only the K-th on, to split a run), each
run as the carry trial with no route (the robot maps by frontiers,
`CarrySetup.mapping='auto'`). First, in the same run, the apartment's trial along its
given route (cup to the bedroom), unless `--no-apartment`. Each row: success, the phase
and cause of a failure, the simulated time and its share exploring, navigating,
searching and manipulating. The JSON is rewritten after every chore, so a long run that
is stopped keeps what it measured.
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from typing import Any

import numpy as np

from robotrial.console import add_json_flag, emit, print_table, progress, write_result
from robotrial.model.homegen import HomeSpec

HELP = "chores in generated 3 x 3 m-room homes, mapped by frontiers: success, causes, time shares"

CHORE_HOMES = HomeSpec(
    rooms=(2, 4),
    room_area=(8.5, 9.5),
    min_side=2.7,
    dock_anywhere=True,
    object_chance=1.0,
    extras=True,
)
ROBOT = "mobile_manipulator"
SEARCHED_SEEDS = 200  # home seeds tried for homes that offer a chore
APARTMENT = ("apartment", "apartment", ("cup", "bedroom"), 1)  # the given-route trial, beside


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--homes", type=int, default=20, help="homes to run chores in")
    parser.add_argument("--first-home", type=int, default=0, help="the first home seed tried")
    parser.add_argument("--chores", type=int, default=3, help="chores a home")
    parser.add_argument(
        "--from-chore",
        type=int,
        default=1,
        metavar="K",
        help="run only each home's chores from its K-th on (e.g. --from-chore 2 --chores 2: "
        "the second chores alone), so a long run can be split; homes with fewer chores "
        "are left out",
    )
    parser.add_argument("--seed", type=int, default=0, help="simulation seed")
    parser.add_argument("--time-limit", type=float, default=600.0, help="simulated seconds a chore")
    parser.add_argument(
        "--no-apartment",
        action="store_true",
        help="leave out the apartment's given-route trial (cup to the bedroom) run first",
    )
    parser.add_argument("-o", "--output", metavar="JSON", help="write the results there")
    add_json_flag(parser)


def chore_homes(
    homes: int, first: int = 0, per_home: int = 3, grip: float = np.inf
) -> list[tuple[int, Any, list]]:
    """The first `homes` home seeds from `first` on whose home, as drawn without its
    extras (`HomeSpec.extras`), offers a chore with an object the gripper holds (narrower
    than `grip`, m) and no twin of it (the same look) in the home: (seed, the World with
    its extras, its chores). A home's chores are those it offered without the extras
    (after the chores of objects with no twin, those of objects whose twins stand only in
    other rooms: the search looks in the object's room alone), then those the extras add,
    up to `per_home`; so the homes and their first chores stay those measured before the
    extras."""
    from dataclasses import replace

    from robotrial.model.homegen import generate_home

    bare = replace(CHORE_HOMES, extras=False)
    out = []
    for seed in range(first, first + SEARCHED_SEEDS):
        if len(out) >= homes:
            break
        alone, apart = _offered(generate_home(seed, spec=bare), grip)
        if not alone:
            continue
        world = generate_home(seed, spec=CHORE_HOMES)
        before = alone + apart
        alone, apart = _offered(world, grip)
        added = [c for c in alone + apart if c not in before]
        out.append((seed, world, (before + added)[:per_home]))
    return out


def _offered(world: Any, grip: float) -> tuple[list, list]:
    """The chores a home offers with objects the gripper holds (narrower than `grip`, m):
    those of objects with no twin (the same look) in the home, and those of objects whose
    twins stand only in other rooms."""
    from robotrial.trials.carry import catalogue_of
    from robotrial.trials.chores import home_chores, room_of

    kinds = catalogue_of(world)
    rooms = {o.name: room_of(world, o) for o in world.objects}
    twins = {
        o.name: [
            rooms[t.name]
            for t in world.objects
            if t.name != o.name and _look(kinds.kind(t.name)) == _look(kinds.kind(o.name))
        ]
        for o in world.objects
    }
    held = [c for c in home_chores(world, 99) if kinds.kind(c[0]).grip_width < grip]
    alone = [c for c in held if not twins[c[0]]]
    apart = [c for c in held if twins[c[0]] and rooms[c[0]] not in twins[c[0]]]
    return alone, apart


def chore_jobs(
    homes: list[tuple[int, Any, list]], from_chore: int = 1
) -> list[tuple[int, Any, tuple[str, str], int]]:
    """The chores to run, (seed, World, chore, its number in the home from 1): each
    home's chores from its `from_chore`-th on, every home's K-th chore before any home's
    (K+1)-th, so a run stopped early covers the homes; a home with fewer adds none."""
    rounds = max((len(chores) for _, _, chores in homes), default=0)
    return [
        (seed, world, chores[k], k + 1)
        for k in range(from_chore - 1, rounds)
        for seed, world, chores in homes
        if k < len(chores)
    ]


def _look(kind: Any) -> tuple:
    return (kind.shape, kind.size, kind.rgb)


def gripper_opening(robot: str) -> float:
    """How wide an object the robot's gripper closes across (m; as `Skills.approach`
    allows, 5 mm under the fingers' full opening)."""
    from robotrial.model import load_robot

    grip = load_robot(robot).metadata.get("gripper") or {}
    return 2 * abs(float(grip.get("open", 0.0)) - float(grip.get("closed", 0.0))) - 0.005


def run(args: argparse.Namespace) -> int:
    from robotrial.trials.carry import CarrySetup, run_carry
    from robotrial.trials.chores import time_shares

    if args.homes < 1 or args.chores < 1:
        raise SystemExit("robotrial bench chores: --homes and --chores must be at least 1")
    if not 1 <= args.from_chore <= args.chores:
        raise SystemExit(
            f"robotrial bench chores: --from-chore must be 1 to --chores ({args.chores}), "
            f"got {args.from_chore}"
        )
    result: dict = {
        "machine": {"cpus": os.cpu_count(), "platform": platform.platform()},
        "date": time.strftime("%Y-%m-%d"),
        "load_average": list(os.getloadavg()),
        "seed": args.seed,
        "rows": [],
    }
    homes = chore_homes(args.homes, args.first_home, args.chores, gripper_opening(ROBOT))
    jobs: list[tuple[Any, Any, tuple[str, str], int]] = [] if args.no_apartment else [APARTMENT]
    jobs += chore_jobs(homes, args.from_chore)
    with progress("bench chores", total=len(jobs), enabled=not args.json) as advance:
        for seed, world, (obj, room), number in jobs:
            row: dict[str, Any] = {
                "home": seed,
                "rooms": 5 if isinstance(world, str) else len(world.rooms),
                "mapping": "route" if isinstance(world, str) else "frontier",
                "chore": f"{obj}:{room}",
                "chore_number": number,
            }
            setup = CarrySetup(world=world, object=obj, to=room, time_limit=args.time_limit)
            try:
                r = run_carry(setup, args.seed)
            except ValueError as exc:
                row.update(success=False, failed_phase="setup", cause="refused", reason=str(exc))
            else:
                row.update(
                    success=r.success,
                    failed_phase=r.failed_phase,
                    cause=r.cause,
                    reason=r.reason,
                    sim_time=round(r.sim_time, 1),
                    shares=time_shares(r.phases),
                    place_error=None if r.place_error is None else round(r.place_error, 4),
                    looks=r.looks,
                    found=r.found,
                    wall_time=round(r.wall_time, 1),
                )
            row["load_average"] = round(os.getloadavg()[0], 2)
            result["rows"].append(row)
            write_result(result, args.output)
            advance()
    result["from_chore"] = args.from_chore
    rows = result["rows"]
    homes_rows = [r for r in rows if r["home"] != "apartment"]
    result["successes"] = sum(r["success"] for r in homes_rows)
    result["chores"] = len(homes_rows)
    result["homes"] = len({r["home"] for r in rows if r["home"] != "apartment"})
    if emit(result, args, load_after=True):
        return 0
    print_table(
        f"bench chores ({result['successes']} of {result['chores']} in {result['homes']} homes, "
        f"seed {args.seed}, load {result['load_average'][0]:.1f})",
        ["home", "#", "chore", "result", "time s", "explore/nav/search/manip s", "wall s"],
        [
            [
                r["home"],
                r["chore_number"],
                r["chore"],
                "success" if r["success"] else f"{r['failed_phase']}: {r['cause']}",
                r.get("sim_time", ""),
                "/".join(f"{v:.0f}" for v in r["shares"].values()) if "shares" in r else "",
                r.get("wall_time", ""),
            ]
            for r in rows
        ],
    )
    return 0
