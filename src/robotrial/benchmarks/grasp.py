"""`robotrial bench grasp`: does the friction grasp hold? (layer 5)

A small MuJoCo scene instead of the apartment: the mobile manipulator's own hand (its
gripper link, fingers and tool point, cut from the robot's description) on three slides,
a table and one catalogue object on it, compiled and run by the same code as the trial
(`sim.build`: elliptic friction cones, torsional friction, the finger servos with their
force limit; `sim.controllers.Gripper`). No attachment: the object stays in the hand only
by friction.

Each grasp: the object stands on the table at a random yaw; the hand comes in along a
side grasp as the carry trial's pick does (the palm stopping `GRASP_MARGIN` short of the
object), aimed where a detector with a given error (`--error`, mm, Gaussian per
horizontal axis) says the object is; it closes with the grip force, lifts 6 cm and is
carried: three drives of 0.4 m in random directions and back, each peaking at 1.2 m/s^2
(the base's limit is 1 m/s^2), the hand tilting up to 40 degrees up or down and back on
each (as the arm's moves between poses tilt it in the trial), 9 s. A grasp
succeeds when the object is still between the fingers at the end; its slip is how far
the object moved in the hand from the closing to the end (mm) and how far it tilted.
Objects wider than the gripper opens are not tried (reported as such).
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np
from scipy.spatial.transform import Rotation

from robotrial.console import add_json_flag, emit, print_table, progress

HELP = "friction grasps of each catalogue object by the mobile manipulator's hand: success, slip"

TABLE_TOP = 0.75  # m
HAND_AXES = ("hand_x", "hand_y", "hand_z")
PITCH = "hand_pitch"
TILT = np.deg2rad(40.0)  # the hand's largest tilt while carried


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--grasps", type=int, default=100, help="grasps per object")
    parser.add_argument("--error", type=float, default=5.0, help="aim error, mm (std per axis)")
    parser.add_argument(
        "--force", type=float, nargs="+", default=[20.0], help="grip forces to try (N)"
    )
    parser.add_argument("--world", default="apartment", help="whose movable objects to grasp")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("-o", "--output", metavar="JSON", help="also write the results here")
    add_json_flag(parser)


def hand_robot(robot_name: str = "mobile_manipulator"):
    """The robot's hand alone on three slides (x, y, z) and a pitch joint, turned for a
    side grasp along +x: its gripper link with everything below it (fingers, tool
    point)."""
    from robotrial.geometry import Pose
    from robotrial.model import load_robot
    from robotrial.model.robot import Inertial, Joint, JointDynamics, JointLimit, Link
    from robotrial.onboard.skills import SIDE_GRASP

    robot = load_robot(robot_name)
    grip = robot.metadata.get("gripper") or {}
    hand = str(grip.get("link") or "")
    keep = {hand}
    joints = []
    for j in robot.topological_joints():
        if j.parent in keep:
            keep.add(j.child)
            joints.append(j)
    mass = Inertial(0.5, Pose(), 1e-3, 0.0, 0.0, 1e-3, 0.0, 1e-3)
    carriers = [Link("hand_mount")] + [Link(n, inertial=mass) for n in HAND_AXES]
    slides = [
        Joint(
            n,
            "prismatic",
            parent,
            n,
            axis=axis,
            limit=JointLimit(lower=-1.0, upper=1.0, effort=200.0, velocity=1.0),
            dynamics=JointDynamics(damping=1.0),
        )
        for n, parent, axis in zip(
            HAND_AXES,
            ("hand_mount", *HAND_AXES[:2]),
            ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
            strict=True,
        )
    ]
    # the hand pitches about the world's y (its approach axis tilting up and down), as
    # the arm's moves between poses tilt it
    pitch = Joint(
        PITCH,
        "revolute",
        HAND_AXES[-1],
        PITCH,
        axis=(0.0, 1.0, 0.0),
        limit=JointLimit(lower=-1.5, upper=1.5, effort=100.0, velocity=3.0),
        dynamics=JointDynamics(damping=0.1),
    )
    quat = tuple(float(v) for v in SIDE_GRASP.as_quat())
    mount = Joint("hand_fixed", "fixed", PITCH, hand, Pose((0.0, 0.0, 0.0), quat))  # type: ignore[arg-type]
    carriers.append(Link(PITCH, inertial=mass))
    slides.append(pitch)
    links = carriers + [lk for lk in robot.links if lk.name in keep]
    return robot.with_changes(
        name=f"{robot.name}_hand",
        links=tuple(links),
        joints=(*slides, mount, *joints),
        sensors=(),
        spheres=(),
        metadata={"gripper": grip},
    ), robot


def _world(obj, yaw: float):
    from robotrial.geometry import Box, Pose
    from robotrial.model.world import Obstacle, World

    table = Obstacle(
        "table",
        Box((0.8, 0.8, TABLE_TOP)),
        Pose((0.0, 0.0, TABLE_TOP / 2)),
        kind="furniture",
    )
    half = _kind(obj).height / 2
    placed = Obstacle(
        obj.name,
        obj.geometry,
        Pose.from_xyz_rpy((0.0, 0.0, TABLE_TOP + half + 0.001), (0.0, 0.0, yaw)),
        obj.rgba,
        obj.mass,
        "object",
    )
    return World(name="grasp", obstacles=(table,), objects=(placed,))


def _kind(obj):
    from robotrial.trials.carry import object_kind

    return object_kind(obj)


def grasp_once(hand, full, obj, force: float, error: float, rng: np.random.Generator) -> dict:
    """One grasp of `obj` with the hand model `hand` (from the robot `full`); figures."""
    from robotrial.geometry import Pose
    from robotrial.kinematics.reference import link_poses
    from robotrial.onboard.skills import GRASP_BACKOFF, GRASP_MARGIN, LIFT, palm_depth
    from robotrial.sim import SimOptions, Simulation
    from robotrial.sim.controllers import JointReference

    kind = _kind(obj)
    world = _world(obj, float(rng.uniform(-np.pi, np.pi)))
    sim = Simulation.create(world, hand, base="fixed", spawn=Pose(), options=SimOptions())
    w = sim.world
    zero = link_poses(full, {})
    palm = palm_depth(full, zero, full.end_effector)
    tcp_in_slides = link_poses(hand, {})[full.end_effector][:3, 3]
    centre = np.array([0.0, 0.0, TABLE_TOP + kind.height / 2])
    aim = centre + np.array([*rng.normal(0.0, error, 2), 0.0])
    depth = kind.grip_width / 2 + palm + GRASP_MARGIN
    grasp = aim - np.array([depth, 0.0, 0.0]) - tcp_in_slides
    pre = grasp - np.array([GRASP_BACKOFF, 0.0, 0.0])
    pre, grasp = np.append(pre, 0.0), np.append(grasp, 0.0)  # the pitch last
    for n, v in zip((*HAND_AXES, PITCH), pre, strict=True):
        w.data.qpos[w.model.jnt_qposadr[w.model.joint(n).id]] = v
    w.forward()
    sim.joints.hold(w.data)
    sim.grip(sim.gripper.open_value, force)
    sim.start()
    sim.advance(0.3)

    def move(points: list[np.ndarray], duration: float) -> None:
        t = np.linspace(0.0, duration, len(points))
        sim.follow(JointReference([*HAND_AXES, PITCH], t, np.array(points)))
        sim.advance(duration + 0.2)

    move([pre, grasp], 1.0)
    sim.grip(sim.gripper.closed_value, force)
    sim.advance(0.8)
    closed_on = 2 * abs(sim.gripper.opening(w.data) - sim.gripper.closed_value)
    squeeze = float(np.max(np.abs(w.data.actuator_force)))
    body = w.body_id(f"object/{obj.name}")
    tcp = w.body_id(full.metadata["gripper"]["link"])

    def in_hand() -> np.ndarray:
        return np.linalg.inv(w.body_pose(tcp)) @ w.body_pose(body)

    held0 = in_hand()
    lifted = grasp + np.array([0.0, 0.0, LIFT, 0.0])
    move([grasp, lifted], 0.8)
    # carried: three drives of 0.4 m in random directions and back, each a smooth start
    # and stop peaking at 1.2 m/s^2 (the base's limit is 1 m/s^2), the hand tilting up to
    # 40 degrees up or down and back on the way, 9 s in all
    t = np.linspace(0.0, 1.3, 27)
    s = 0.5 - 0.5 * np.cos(np.pi * t / 1.3)
    bump = np.sin(np.pi * t / 1.3)
    for _ in range(3):
        d = rng.normal(size=2)
        away = lifted + np.array([*(0.4 * d / np.linalg.norm(d)), 0.0, 0.0])
        tilt = float(rng.uniform(-TILT, TILT))
        for a, b in ((lifted, away), (away, lifted)):
            path = a + np.outer(s, b - a)
            path[:, 3] = tilt * bump
            sim.follow(JointReference([*HAND_AXES, PITCH], t, path))
            sim.advance(1.5)
    held1 = in_hand()
    rel = held1[:3, 3] - held0[:3, 3]
    tilt = np.rad2deg(Rotation.from_matrix(held0[:3, :3].T @ held1[:3, :3]).magnitude())
    height = float(w.data.xpos[body][2]) - TABLE_TOP
    width = 2 * abs(sim.gripper.opening(w.data) - sim.gripper.closed_value)
    held = height > LIFT / 2 and width > kind.grip_width - 0.012
    sim.close()
    return {
        "held": bool(held),
        "slip_mm": float(np.linalg.norm(rel) * 1e3),
        "tilt_deg": float(tilt),
        "aim_error_mm": float(np.linalg.norm((aim - centre)[:2]) * 1e3),
        "closed_on_mm": float(closed_on * 1e3),
        "squeeze_n": squeeze,
    }


def run(args: argparse.Namespace) -> int:
    from robotrial.model import load_world

    if args.grasps < 1:
        print("robotrial bench grasp: --grasps must be at least 1")
        return 2
    hand, full = hand_robot()
    opening = 2 * abs(
        float(full.metadata["gripper"]["open"]) - float(full.metadata["gripper"]["closed"])
    )
    objects = load_world(args.world).objects
    rng = np.random.default_rng(args.seed)
    rows, out = [], []
    total = args.grasps * len(objects) * len(args.force)
    t0 = time.perf_counter()
    with progress("bench grasp", total=total, enabled=not args.json) as advance:
        for obj in objects:
            kind = _kind(obj)
            for force in args.force:
                if kind.grip_width > opening - 0.005:
                    why = (
                        f"{100 * kind.grip_width:.1f} cm across, the fingers open "
                        f"{100 * opening:.1f} cm"
                    )
                    out.append({"object": obj.name, "force": force, "tried": 0, "why": why})
                    rows.append([obj.name, force, 0, "-", "-", "-", "-", why])
                    advance(args.grasps)
                    continue
                runs = []
                for _ in range(args.grasps):
                    runs.append(grasp_once(hand, full, obj, force, args.error / 1000, rng))
                    advance()
                held = [r for r in runs if r["held"]]
                slips = np.array([r["slip_mm"] for r in held]) if held else np.zeros(1)
                tilts = np.array([r["tilt_deg"] for r in held]) if held else np.zeros(1)
                entry = {
                    "object": obj.name,
                    "force": force,
                    "tried": len(runs),
                    "held": len(held),
                    "slip_mm_median": float(np.median(slips)),
                    "slip_mm_max": float(np.max(slips)),
                    "tilt_deg_max": float(np.max(tilts)),
                }
                out.append(entry)
                rows.append(
                    [
                        obj.name,
                        force,
                        len(runs),
                        f"{len(held)}/{len(runs)}",
                        entry["slip_mm_median"],
                        entry["slip_mm_max"],
                        entry["tilt_deg_max"],
                        "",
                    ]
                )
    result = {
        "machine": f"{platform.machine()}, {os.cpu_count()} cores",
        "load_average": os.getloadavg()[0],
        "aim_error_mm": args.error,
        "wall_time": time.perf_counter() - t0,
        "objects": out,
    }
    if emit(result, args):
        return 0
    print_table(
        f"friction grasps, aim error {args.error:g} mm per axis",
        [
            "object",
            "force (N)",
            "grasps",
            "held",
            "slip median (mm)",
            "slip max (mm)",
            "tilt max (deg)",
            "not tried",
        ],
        rows,
    )
    return 0
