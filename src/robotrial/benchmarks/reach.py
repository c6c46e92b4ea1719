"""`robotrial bench reach`: how far in from a top's edge the arm takes an object (layer 5).

The mobile manipulator's skills (`onboard/skills.py`) asked, without the simulator, whether
the arm gets to an object on a top and away with it: `Skills._reaches`, the grasp, its
pre-grasp and the lift, then, holding it, the way back down, planned with the arm's IK
and collision checks in the voxels of the top as the head camera sees it (its top face
as a slab, its front face as voxels), from the stow pose. The top is 0.6 m deep and 2 m
wide; the object stands straight ahead of the arm `d` in from its edge, `d` in steps of
`--step`. Each `d` is tried from the work sites the skills offer (`REACHES`, arm base to
object) whose base keeps `EDGE_GAP` or more off the edge, as the map lets it stand, with
the torso lift at each of the heights the skills raise it to (`--lifts` restricts them:
`--lifts 0` is the arm on the lowered lift alone).

    robotrial bench reach                       # tops 0.45-0.9 m; can and book
    robotrial bench reach --heights 0.9 --step 0.02 -o reach.json
    robotrial bench reach --lifts 0             # the lift kept lowered
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from types import SimpleNamespace

import numpy as np

from robotrial.console import add_json_flag, emit, print_table, progress

HELP = "how far in from a top's edge the mobile manipulator's arm grasps, lifts and sets down"

EDGE_GAP = 0.05  # m from the base's front to the top's edge, as the map lets it stand
TOP_DEPTH = 0.6  # m
TOP_WIDTH = 2.0  # m
# the home generator's objects the chores carry: name, cube side (m); cups are wider
# than the gripper opens
KINDS = (("can", 0.07), ("book", 0.06))


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--robot", default="mobile_manipulator", help="built-in robot name")
    parser.add_argument(
        "--heights",
        type=float,
        nargs="+",
        default=[0.45, 0.5, 0.75, 0.8, 0.9],
        help="top heights (m)",
    )
    parser.add_argument(
        "--lifts",
        type=float,
        nargs="+",
        metavar="M",
        help="the torso lift's heights to try (m; default: every one the skills use)",
    )
    parser.add_argument("--step", type=float, default=0.05, help="step in from the edge (m)")
    parser.add_argument("-o", "--output", metavar="JSON", help="also write the results here")
    add_json_flag(parser)


def skills_at_stow(robot_name: str, kinds):
    """The robot's skills with its arm in the stow pose and no simulator: enough to ask
    whether the arm gets somewhere (`Skills._reaches`)."""
    from robotrial.model import load_robot
    from robotrial.onboard.catalogue import Catalogue
    from robotrial.onboard.skills import Skills
    from robotrial.trials.nav_goals import footprint_of_robot

    model = load_robot(robot_name)
    stow = dict(model.metadata["poses"]["stow"])
    setup = SimpleNamespace(
        footprint=footprint_of_robot(robot_name), planner="rrt_connect", seed=0, grip_force=20
    )
    robot = SimpleNamespace(model=model, setup=setup, joints=stow)
    return Skills(robot, Catalogue(kinds))  # type: ignore[arg-type]


def top_seen(skills, height: float, edge: float) -> None:
    """Give the skills' voxels what the head camera makes of a top `height` high,
    TOP_DEPTH deep and TOP_WIDTH wide, its edge `edge` ahead of the base frame's origin
    along +x: its top face a slab, its front face voxels."""
    from robotrial.onboard.voxels import SLAB_CELL

    res = skills.voxels.resolution
    ys = np.arange(-TOP_WIDTH / 2, TOP_WIDTH / 2, res)
    front = np.stack(np.meshgrid([edge + res / 2], ys, np.arange(0.05, height - res, res)), axis=-1)
    skills.voxels.keys = np.unique(np.floor(front.reshape(-1, 3) / res).astype(np.int64), axis=0)
    i = range(int(np.floor(edge / SLAB_CELL)), int(np.floor((edge + TOP_DEPTH) / SLAB_CELL)))
    j = range(int(np.floor(-TOP_WIDTH / 2 / SLAB_CELL)), int(np.floor(TOP_WIDTH / 2 / SLAB_CELL)))
    skills.voxels.slabs = {(a, b): height for a in i for b in j}


def takes_and_sets_down(skills, kind, height: float, inward: float, reach: float):
    """How the arm grasps and lifts an object of `kind` `inward` in from the edge of a
    top `height` high, the base standing so that the object is `reach` ahead of the
    arm's base (a `skills.Way`: the grasp's pitch and the lift's height), when, holding
    it, it sets it down there again too; else None."""
    x = skills.arm_offset + reach
    top_seen(skills, height, x - inward)
    obj = np.array([x, 0.0, height + kind.height / 2])
    skills.held = None
    way = skills._reaches(np.zeros(3), obj, kind)
    if way is None:
        return None
    return way if sets_down(skills, kind, height, inward, reach, way.pitch) else None


def sets_down(skills, kind, height: float, inward: float, reach: float, pitch: float):
    """How the arm, holding an object of `kind` grasped at `pitch` (rad down), sets it
    down `inward` in from the edge of a top `height` high, the object `reach` ahead of
    the arm's base (a `skills.Way`), else None."""
    from robotrial.onboard.skills import Held

    x = skills.arm_offset + reach
    top_seen(skills, height, x - inward)
    obj = np.array([x, 0.0, height + kind.height / 2])
    back = kind.grip_width / 2 + skills.palm
    skills.held = Held(kind, np.array([0.0, 0.0, back]), kind.grip_width, pitch)
    try:
        return skills._reaches(np.zeros(3), obj, kind)
    finally:
        skills.held = None


def first(reaches, check, *args, **kwargs):
    """The first way `check(*args, reach, **kwargs)` finds over `reaches`, else None."""
    return next((w for r in reaches if (w := check(*args, float(r), **kwargs)) is not None), None)


def run(args: argparse.Namespace) -> int:
    from robotrial.onboard.catalogue import ObjectKind
    from robotrial.onboard.skills import PITCHES, REACHES

    if args.step <= 0 or not args.heights:
        print("robotrial bench reach: --step must be positive and --heights name a height")
        return 2
    kinds = [ObjectKind(n, "box", (s, s, s), (0.5, 0.5, 0.5)) for n, s in KINDS]
    load = list(os.getloadavg())
    t0 = time.perf_counter()
    skills = skills_at_stow(args.robot, kinds)
    if args.lifts is not None:
        unknown = sorted(set(args.lifts) - set(skills.lifts))
        if unknown:
            known = ", ".join(f"{h:g}" for h in skills.lifts)
            print(f"robotrial bench reach: --lifts {unknown} not among the lift's heights {known}")
            return 2
        skills.lifts = tuple(args.lifts)
    front = skills.footprint.length / 2
    inwards = np.round(np.arange(args.step, TOP_DEPTH - 0.05 + 1e-9, args.step), 3)
    out, rows = [], []
    total = len(args.heights) * len(kinds) * len(inwards)
    with progress("bench reach", total=total, enabled=not args.json) as advance:
        for height in args.heights:
            for kind in kinds:
                # the deepest step taken (and set down again) and the deepest step an
                # object held as a grasp from a table holds it (PITCHES[0]) is set down,
                # each while every step before it succeeded too
                lifts: list[float] = []
                placed: list[float] = []
                taking = putting = True
                for k, d in enumerate(inwards):
                    # work sites whose base front keeps EDGE_GAP off the edge
                    sites = [r for r in REACHES if skills.arm_offset + r - d >= front + EDGE_GAP]
                    if taking:
                        took = first(sites, takes_and_sets_down, skills, kind, height, d)
                        taking = took is not None
                        lifts += [took.lift] if took is not None else []
                    if putting:
                        put = first(sites, sets_down, skills, kind, height, d, pitch=PITCHES[0])
                        putting = put is not None
                        placed += [put.lift] if put is not None else []
                    advance()
                    if not (taking or putting):  # further in is not tried
                        advance(len(inwards) - k - 1)
                        break
                upto = float(inwards[len(lifts) - 1]) if lifts else 0.0
                down = float(inwards[len(placed) - 1]) if placed else 0.0
                out.append(
                    {
                        "height": height,
                        "object": kind.name,
                        "every_step_up_to": round(upto, 3),
                        "lift_at_each_step": lifts,
                        "set_down_every_step_up_to": round(down, 3),
                        "set_down_lift_at_each_step": placed,
                    }
                )
                rows.append(
                    [
                        f"{height:.2f}",
                        kind.name,
                        f"{upto:.2f}",
                        ", ".join(f"{h:g}" for h in sorted(set(lifts))) or "-",
                        f"{down:.2f}",
                        ", ".join(f"{h:g}" for h in sorted(set(placed))) or "-",
                    ]
                )
    model = skills.model
    result = {
        "machine": f"{platform.machine()}, {os.cpu_count()} cores",
        "load_average": load,
        "robot": model.name,
        "arm_base_ahead_of_middle": skills.arm_offset,
        "shoulder": [float(v) for v in skills.shoulder],
        "base_front": front,
        "edge_gap": EDGE_GAP,
        "work_site_reaches": list(REACHES),
        "lifts": list(skills.lifts),
        "wall_time": time.perf_counter() - t0,
        "tops": out,
    }
    if emit(result, args, load_after=True):
        return 0
    print_table(
        f"how far in from a top's edge the arm takes an object and sets it down "
        f"({model.name}: arm base {skills.arm_offset:.3f} m ahead of the middle, shoulder "
        f"{skills.shoulder[2]:.3f} m above the base frame)",
        [
            "top m",
            "object",
            "taken and set down up to m",
            "lift m",
            f"set down, held at {np.rad2deg(PITCHES[0]):.0f} deg, up to m",
            "lift m",
        ],
        rows,
    )
    return 0
