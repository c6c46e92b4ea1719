"""`robotrial bench perception`: the object detector on simulated views, and the arm
planner on the voxel scene the camera makes (layer 5).

Detector: the mobile manipulator's head RGB-D pair looks at a table from a random
distance (0.8-3 m from the base to the table's near object) and bearing (-30 to 30
degrees off the camera's axis); on the table stand the target object (a random kind of
the catalogue, at a random yaw) and 0-4 other catalogue objects (clutter). One MuJoCo
world holds them all: a view moves the base and the objects and renders, as the trial
does, the colour and the depth image with the sensor's noise. The robot's own body is cut
out of the points as on the robot (`onboard.voxels.RobotBody`), the detector runs with
the stride the robot uses at that distance (every pixel within `NEAR` m, every other row
and column farther), and its detections are matched to the objects in view (at least
`VISIBLE` pixels of them in a segmentation render): a detection of the right kind within
5 cm of an object in view is a true positive; any other detection with a kind is a false
positive; unknown clusters are neither. Figures: precision, recall, and the error of the
centre (in the plane and in 3D), by distance band.

Planner on voxels: from a few of those views the voxel map of what the camera saw (the
robot cut out) becomes the arm's obstacles, as boxes of merged voxels; RRTConnect plans
from the stow pose to a grasp of the target and back, timed, beside the same queries
among the table as one box (what a world file would give).
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np

from robotrial.console import add_json_flag, print_json, print_table, progress

HELP = "object detector on 200 simulated views (precision, recall, pose error); planning on voxels"

TABLE = (1.2, 0.8, 0.75)  # m, the table's size
NEAR = 1.5  # m: views this close are looked at with every pixel
VISIBLE = 40  # pixels of an object that make it "in view"
MATCH = 0.05  # m
BANDS = ((0.8, 1.5), (1.5, 2.2), (2.2, 3.0))


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--views", type=int, default=200, help="simulated views")
    parser.add_argument("--plans", type=int, default=10, help="views whose voxels are planned in")
    parser.add_argument("--world", default="apartment", help="whose movable objects to use")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("-o", "--output", metavar="JSON", help="also write the results here")
    add_json_flag(parser)


class Views:
    """One MuJoCo world with the table and every catalogue object; `show` arranges a
    view and renders it."""

    def __init__(self, world_name: str, seed: int) -> None:
        from robotrial.geometry import Box, Pose
        from robotrial.model import load_robot, load_world
        from robotrial.model.world import Obstacle, World
        from robotrial.sim import SimOptions, Simulation, StreamSettings
        from robotrial.trials.carry import catalogue_of

        source = load_world(world_name)
        self.catalogue = catalogue_of(source)
        self.objects = source.objects
        table = Obstacle(
            "table",
            Box(TABLE),
            Pose((0.0, 0.0, TABLE[2] / 2)),
            rgba=(0.6, 0.45, 0.3, 1.0),
            kind="furniture",
        )
        far = tuple(
            Obstacle(o.name, o.geometry, Pose((-20.0 - 2 * i, 0.0, 1.0)), o.rgba, o.mass, "object")
            for i, o in enumerate(self.objects)
        )
        world = World(name="views", obstacles=(table,), objects=far)
        self.robot = load_robot("mobile_manipulator")
        off = StreamSettings(enabled=False)
        streams = {s.name: off for s in self.robot.sensors}
        self.sim = Simulation.create(
            world,
            self.robot,
            seed=seed,
            spawn=Pose(),
            options=SimOptions(cameras=False, streams=streams),
        )
        import mujoco

        m = self.sim.world.model
        from robotrial.sim.build import RAY_GROUP

        self.seg = mujoco.Renderer(m, 480, 640)
        self.seg.enable_segmentation_rendering()
        self.seg_option = mujoco.MjvOption()
        self.seg_option.geomgroup[RAY_GROUP] = 1
        self.bodies = {o.name: self.sim.world.body_id(f"object/{o.name}") for o in self.objects}
        self.geoms = {
            name: {g for g in range(m.ngeom) if int(m.geom_bodyid[g]) == b}
            for name, b in self.bodies.items()
        }
        stow = self.robot.metadata["poses"]["stow"]
        d = self.sim.world.data
        for n, v in stow.items():
            d.qpos[m.jnt_qposadr[m.joint(n).id]] = v
        self.joints = {**{j.name: 0.0 for j in self.robot.actuated_joints}, **stow}
        self.joints["arm_finger_left"] = float(self.robot.metadata["gripper"]["open"])

    def show(self, base: tuple[float, float, float], placed: dict[str, tuple[float, float, float]]):
        """Put the base at `base` and the objects at (x, y, yaw) on the table (others far
        away); the RGB-D frame (base frame) and the pixels seen of each object."""
        import mujoco
        from scipy.spatial.transform import Rotation

        from robotrial.onboard.camera import RgbdFrame
        from robotrial.sim.tf import chain_to_root

        w = self.sim.world
        m, d = w.model, w.data
        for i, o in enumerate(self.objects):
            adr = m.jnt_qposadr[m.body_jntadr[self.bodies[o.name]]]
            if o.name in placed:
                x, y, yaw = placed[o.name]
                z = TABLE[2] + self.catalogue.kind(o.name).height / 2
                q = Rotation.from_euler("z", yaw).as_quat()
                d.qpos[adr : adr + 7] = [x, y, z, q[3], q[0], q[1], q[2]]
            else:
                d.qpos[adr : adr + 7] = [-20.0 - 2 * i, 0.0, 1.0, 1, 0, 0, 0]
        for name, v in zip(("base_x", "base_y", "base_yaw"), base, strict=True):
            d.qpos[m.jnt_qposadr[m.joint(name).id]] = v
        mujoco.mj_forward(m, d)
        depth = self.sim.capture("head_depth")[0].data
        colour = self.sim.capture("head_camera")[0].data
        tf = self.sim.tf.static + self.sim.tf.dynamic(self.sim.joint_values())
        cam = chain_to_root(tf, depth.frame, self.robot.root)
        frame = RgbdFrame(depth.pixels, colour.pixels, depth.intrinsics(), cam, depth.stamp)
        self.seg.update_scene(d, camera="head_depth", scene_option=self.seg_option)
        ids = self.seg.render()[:, :, 0]
        seen = {name: int(np.isin(ids, list(gs)).sum()) for name, gs in self.geoms.items()}
        return frame, seen

    def truth(self, name: str) -> np.ndarray:
        """An object's centre in the base frame."""
        w = self.sim.world
        base = np.linalg.inv(w.body_pose(w.base_body))
        return (base @ np.append(w.data.xpos[self.bodies[name]], 1.0))[:3]

    def close(self) -> None:
        self.seg.close()
        self.sim.close()


def _arrange(views: Views, rng: np.random.Generator):
    """A random view: the target and clutter on the table, the base at a distance and
    bearing from the target. Returns the base pose, the placements, the target, the
    distance and the bearing (deg)."""
    names = [o.name for o in views.objects]
    target = str(rng.choice(names))
    clutter = int(rng.integers(0, min(4, len(names) - 1) + 1))
    others = list(rng.permutation([n for n in names if n != target])[:clutter])
    placed: dict[str, tuple[float, float, float]] = {}
    footprints: list[tuple[float, float, float]] = []
    for name in [target, *others]:
        kind = views.catalogue.kind(name)
        r = 0.5 * float(np.hypot(*kind.size[:2]))
        for _ in range(50):
            x = rng.uniform(-TABLE[0] / 2 + r, TABLE[0] / 2 - r)
            y = rng.uniform(-TABLE[1] / 2 + r, TABLE[1] / 2 - r)
            if all(np.hypot(x - a, y - b) > r + c + 0.02 for a, b, c in footprints):
                placed[name] = (x, y, float(rng.uniform(-np.pi, np.pi)))
                footprints.append((x, y, r))
                break
    tx, ty, _ = placed[target]
    distance = float(rng.uniform(0.8, 3.0))
    heading = float(rng.uniform(-np.pi, np.pi))
    bearing = float(rng.uniform(-30.0, 30.0))
    # the camera stands `distance` from the target, the target `bearing` off its axis;
    # move back while the base would stand on the table
    for _ in range(20):
        bx, by = tx - distance * np.cos(heading), ty - distance * np.sin(heading)
        if abs(bx) > TABLE[0] / 2 + 0.6 or abs(by) > TABLE[1] / 2 + 0.6:
            break
        distance += 0.1
    yaw = heading - np.deg2rad(bearing)
    return (bx, by, yaw), placed, target, distance, bearing


def run(args: argparse.Namespace) -> int:
    from robotrial.onboard.perception import ObjectDetector
    from robotrial.onboard.voxels import RobotBody

    if args.views < 1:
        print("robotrial bench perception: --views must be at least 1")
        return 2
    rng = np.random.default_rng(args.seed)
    views = Views(args.world, args.seed)
    detector = ObjectDetector(views.catalogue)
    body = RobotBody(views.robot)
    records = []
    kept = []
    t0 = time.perf_counter()
    with progress(
        "bench perception", total=args.views + args.plans, enabled=not args.json
    ) as advance:
        for v in range(args.views):
            base, placed, target, distance, bearing = _arrange(views, rng)
            frame, seen = views.show(base, placed)
            stride = 1 if distance <= NEAR else 2
            t = time.perf_counter()
            pts, colours = frame.points(stride)
            keep = ~body.mask(pts, views.joints)
            pts, colours = pts[keep], colours[keep] if colours is not None else None
            found = detector.detect(pts, colours, frame.viewpoint)
            took = time.perf_counter() - t
            in_view = {n for n in placed if seen[n] >= VISIBLE}
            truth = {n: views.truth(n) for n in placed}
            tp, fp, errors = 0, 0, []
            matched: set[str] = set()
            for d in found:
                if not d.kind:
                    continue
                p = np.asarray(d.position)
                if d.kind in in_view and d.kind not in matched:
                    e = truth[d.kind] - p
                    if np.hypot(e[0], e[1]) <= MATCH:
                        tp += 1
                        matched.add(d.kind)
                        errors.append(
                            (d.kind, float(np.hypot(e[0], e[1])), float(np.linalg.norm(e)))
                        )
                        continue
                fp += 1
            records.append(
                {
                    "view": v,
                    "distance": distance,
                    "bearing": bearing,
                    "clutter": len(placed) - 1,
                    "target": target,
                    "in_view": sorted(in_view),
                    "target_found": target in matched,
                    "tp": tp,
                    "fp": fp,
                    "errors": errors,
                    "stride": stride,
                    "detect_ms": 1e3 * took,
                }
            )
            if len(kept) < args.plans and distance <= NEAR and target in matched:
                kept.append((frame, pts, base, truth[target]))
            advance()
        plans = _plans(views, kept, advance)
    views.close()
    result = {
        "machine": f"{platform.machine()}, {os.cpu_count()} cores",
        "load_average": os.getloadavg()[0],
        "views": len(records),
        "wall_time": time.perf_counter() - t0,
        "bands": _bands(records),
        "all": _summary(records),
        "targets_found": sum(r["target_found"] for r in records if r["target"] in r["in_view"]),
        "targets_in_view": sum(r["target"] in r["in_view"] for r in records),
        "planning": plans,
    }
    if args.output:
        import json

        Path(args.output).write_text(json.dumps({**result, "records": records}, indent=2))
    if args.json:
        print_json(result)
        return 0
    rows = [
        [
            b["band"],
            b["views"],
            b["in_view"],
            b["precision"],
            b["recall"],
            b["error_median_mm"],
            b["error_p95_mm"],
            b["error_max_mm"],
            b["detect_ms_median"],
        ]
        for b in [*result["bands"], {**result["all"], "band": "all"}]
    ]
    print_table(
        f"detector, {len(records)} views (load {result['load_average']:.1f})",
        [
            "distance (m)",
            "views",
            "objects in view",
            "precision",
            "recall",
            "centre error median (mm)",
            "p95 (mm)",
            "max (mm)",
            "ms per view",
        ],
        rows,
    )
    if plans:
        print_table(
            "arm planning: voxels seen by the camera vs the table as one box",
            ["scene", "queries", "solved", "obstacles (median)", "planning ms median", "p95"],
            [
                [p["scene"], p["queries"], p["solved"], p["obstacles"], p["ms_median"], p["ms_p95"]]
                for p in plans
            ],
        )
    return 0


def _summary(records: list[dict]) -> dict:
    tp = sum(r["tp"] for r in records)
    fp = sum(r["fp"] for r in records)
    in_view = sum(len(r["in_view"]) for r in records)
    errs = np.array([e[1] for r in records for e in r["errors"]]) * 1e3
    ms = np.array([r["detect_ms"] for r in records])
    return {
        "views": len(records),
        "in_view": in_view,
        "precision": round(tp / (tp + fp), 3) if tp + fp else None,
        "recall": round(tp / in_view, 3) if in_view else None,
        "error_median_mm": round(float(np.median(errs)), 1) if len(errs) else None,
        "error_p95_mm": round(float(np.percentile(errs, 95)), 1) if len(errs) else None,
        "error_max_mm": round(float(np.max(errs)), 1) if len(errs) else None,
        "detect_ms_median": round(float(np.median(ms)), 0) if len(ms) else None,
    }


def _bands(records: list[dict]) -> list[dict]:
    out = []
    for lo, hi in BANDS:
        sel = [
            r
            for r in records
            if lo <= r["distance"] < hi or (hi == BANDS[-1][1] and r["distance"] >= lo)
        ]
        out.append({"band": f"{lo:g}-{hi:g}", **_summary(sel)})
    return out


def _plans(views: Views, kept: list, advance) -> list[dict]:
    """Plan the arm from the stow pose to a grasp of the target and back in the voxels
    of a view, and among the table as one box; planning times."""
    from scipy.spatial.transform import Rotation

    from robotrial.geometry import Box, Pose
    from robotrial.onboard.skills import GRASP_BACKOFF, SIDE_GRASP
    from robotrial.onboard.voxels import VoxelMap
    from robotrial.planning.task import TaskPlanner, TaskRequest

    if not kept:
        return []
    planner = TaskPlanner(views.robot, validate=False)
    names = planner.joint_names
    stow = np.array([views.robot.metadata["poses"]["stow"][n] for n in names])
    floor = ("floor", Box((4.0, 4.0, 0.1)), Pose((0.0, 0.0, -0.05)))
    stats: dict[str, list] = {"voxels": [], "world box": []}
    sizes: dict[str, list] = {"voxels": [], "world box": []}
    for frame, pts, base, centre in kept:
        vm = VoxelMap()
        vm.integrate(frame, pts, np.asarray(base))
        keep_out = [(centre, 0.08, centre[2] - 0.06, centre[2] + 0.1)]
        table_box = views.sim.world.body_pose(views.sim.world.base_body)
        inv = np.linalg.inv(table_box)
        table = Pose.from_matrix(inv @ Pose((0.0, 0.0, TABLE[2] / 2)).matrix())
        scenes = {
            "voxels": [floor, *vm.boxes(np.asarray(base), keep_out=keep_out)],
            "world box": [floor, ("table", Box(TABLE), table)],
        }
        d = centre[:2] - np.array([0.2, 0.0])
        yaw = float(np.arctan2(d[1], d[0]))
        goal = centre - np.array([np.cos(yaw), np.sin(yaw), 0.0]) * (0.02 + GRASP_BACKOFF)
        quat = (Rotation.from_euler("z", yaw) * SIDE_GRASP).as_quat()
        for scene, obstacles in scenes.items():
            sizes[scene].append(len(obstacles))
            there = planner.plan(
                TaskRequest(stow, goal, quat, names, obstacles, time_limit=2.0), seed=0
            )
            stats[scene].append((there.success, there.planning_time))
            if there.success:
                back = planner.plan(
                    TaskRequest(
                        there.trajectory.q[-1],
                        np.zeros(3),
                        None,
                        names,
                        obstacles,
                        goal_joints=stow,
                        time_limit=2.0,
                    ),
                    seed=1,
                )
                stats[scene].append((back.success, back.planning_time))
        advance()
    out = []
    for scene, runs in stats.items():
        ms = np.array([t for ok, t in runs if ok]) * 1e3
        out.append(
            {
                "scene": scene,
                "queries": len(runs),
                "solved": sum(ok for ok, _ in runs),
                "obstacles": int(np.median(sizes[scene])),
                "ms_median": round(float(np.median(ms)), 1) if len(ms) else None,
                "ms_p95": round(float(np.percentile(ms, 95)), 1) if len(ms) else None,
            }
        )
    return out
