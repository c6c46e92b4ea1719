"""`robotrial bench perception`: the object detector on simulated views, and the arm
planner on the voxel scene the camera makes (layer 5).

Detector: the mobile manipulator's head RGB-D pair looks at a table from a random
distance (0.8-3 m from the base to the table's near object) and bearing (-30 to 30
degrees off the camera's axis); on the table stand the target object (a random kind of
the catalogue, at a random yaw) and 0-4 other catalogue objects (clutter). One MuJoCo
world holds them all: a view moves the base and the objects and renders, as the trial
does, the colour and the depth image with the sensor's noise. The robot's own body is cut
out of the points as on the robot (`onboard.voxels.RobotBody`), the detector runs on
every pixel (as the robot's looks do: with every other row and column, objects beyond
2.2 m have too few points to be found), and its detections are matched to the objects in
view (at least
`VISIBLE` pixels of them in a segmentation render): a detection of the right kind within
5 cm of an object in view is a true positive; any other detection with a kind is a false
positive; unknown clusters are neither. Figures: precision, recall, and the error of the
centre (in the plane and in 3D), by distance band.

Planner on voxels: at `--plans` work sites as the trial's pick has them (the base 0.7 m
from a graspable object near the end of the table, clutter 0-4), the voxel map of what
the camera saw (the robot cut out, the table top as a slab) becomes the arm's obstacles,
as the robot gives them to the planner (`onboard.skills`); RRTConnect plans from the stow
pose to the pre-grasp and back, set up once by `VoxelChecker` and once by the general
`CollisionChecker`, beside the same queries among the table as one box (what a world
file would give). Times are whole requests (IK, planning, smoothing, timing; no MuJoCo
validation), the scene set-up and RRTConnect alone.
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


def _work_site(views: Views, rng: np.random.Generator, graspable: list[str]):
    """A pick as the trial makes it: a graspable target 10 cm in from the end of the
    table, the base 0.7 m from it facing it along the table, clutter 0-4; the base pose
    and the placements."""
    target = str(rng.choice(graspable))
    side = float(rng.choice([-1.0, 1.0]))
    tx, ty = side * (TABLE[0] / 2 - 0.1), float(rng.uniform(-0.25, 0.25))
    placed = {target: (tx, ty, float(rng.uniform(-np.pi, np.pi)))}
    others = [o.name for o in views.objects if o.name != target]
    spots = [(0.0, 0.2), (0.0, -0.2), (-0.25 * side, 0.25), (-0.25 * side, -0.25)]
    chosen = rng.permutation(others)[: int(rng.integers(0, 5))]
    for name, (x, y) in zip(chosen, spots[: len(chosen)], strict=True):
        placed[str(name)] = (x, y, float(rng.uniform(-np.pi, np.pi)))
    yaw = np.pi if side > 0 else 0.0
    return (tx + side * 0.7, ty, yaw), placed, target


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
            stride = 1
            t = time.perf_counter()
            pts, colours = frame.points(stride)
            keep = ~body.mask(pts, views.joints)
            pts, colours = pts[keep], colours[keep] if colours is not None else None
            found = detector.detect(pts, colours, frame.viewpoint, None, stride / frame.k[0])
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
            advance()
        graspable = [
            o.name for o in views.objects if views.catalogue.kind(o.name).grip_width < 0.075
        ]
        for _ in range(args.plans):
            base, placed, target = _work_site(views, rng, graspable)
            frame, _ = views.show(base, placed)
            pts, _ = frame.points(1)
            kept.append((frame, pts[~body.mask(pts, views.joints)], base, views.truth(target)))
        if args.output:  # the detector's figures are kept should the planning fail
            import json

            Path(args.output).write_text(json.dumps({"records": records}, indent=2))
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
            [
                "scene",
                "queries",
                "solved",
                "obstacles",
                "request ms median",
                "p95",
                "scene set-up ms",
                "RRTConnect ms",
            ],
            [
                [
                    p["scene"],
                    p["queries"],
                    p["solved"],
                    p["obstacles"],
                    p["ms_median"],
                    p["ms_p95"],
                    p["scene_ms_median"],
                    p["planner_ms_median"],
                ]
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
    of a view (the robot's own obstacles: `onboard.skills`), set up by the voxel checker
    and by the general one, and among the table as one box; planning times."""
    from scipy.spatial.transform import Rotation

    from robotrial.collision.voxels import VoxelChecker
    from robotrial.geometry import Box, Pose
    from robotrial.onboard.perception import ObjectDetector
    from robotrial.onboard.skills import GRASP_BACKOFF, SIDE_GRASP, arm_reach
    from robotrial.onboard.voxels import VoxelMap
    from robotrial.planning.task import TaskPlanner, TaskRequest

    if not kept:
        return []
    planners = {
        "voxels, voxel checker": TaskPlanner(views.robot, validate=False, checker=VoxelChecker),
        "voxels, general checker": TaskPlanner(views.robot, validate=False),
        "table as one box": TaskPlanner(views.robot, validate=False),
    }
    general = planners["voxels, general checker"]
    names = general.joint_names
    shoulder, reach = arm_reach(general)
    stow = np.array([views.robot.metadata["poses"]["stow"][n] for n in names])
    floor = ("floor", Box((4.0, 4.0, 0.1)), Pose((0.0, 0.0, -0.05)))
    detector = ObjectDetector(views.catalogue)
    runs: dict[str, list] = {k: [] for k in planners}
    sizes: dict[str, list] = {k: [] for k in planners}
    for frame, pts, base, centre in kept:
        vm = VoxelMap()
        vm.integrate(frame, pts, np.asarray(base), detector.surfaces(pts))
        keep_out = [(centre, 0.08, centre[2] - 0.06, centre[2] + 0.1)]
        inv = np.linalg.inv(views.sim.world.body_pose(views.sim.world.base_body))
        table = Pose.from_matrix(inv @ Pose((0.0, 0.0, TABLE[2] / 2)).matrix())
        voxels = [floor, *vm.boxes(np.asarray(base), shoulder, reach + 0.05, keep_out)]
        scenes = {
            "voxels, voxel checker": voxels,
            "voxels, general checker": voxels,
            "table as one box": [floor, ("table", Box(TABLE), table)],
        }
        d = centre[:2] - np.array([0.2, 0.0])
        yaw = float(np.arctan2(d[1], d[0]))
        goal = centre - np.array([np.cos(yaw), np.sin(yaw), 0.0]) * (0.02 + GRASP_BACKOFF)
        quat = (Rotation.from_euler("z", yaw) * SIDE_GRASP).as_quat()
        for scene, obstacles in scenes.items():
            planner = planners[scene]
            sizes[scene].append(len(obstacles))
            there = planner.plan(TaskRequest(stow, goal, quat, names, obstacles, time_limit=2.0), 0)
            runs[scene].append(there)
            if there.success:
                back = TaskRequest(
                    there.trajectory.q[-1], np.zeros(3), None, names, obstacles, time_limit=2.0
                )
                back.goal_joints = stow
                runs[scene].append(planner.plan(back, 1))
        advance()
    out = []
    for scene, results in runs.items():
        ok = [r for r in results if r.success]
        total = np.array([r.planning_time for r in ok]) * 1e3
        build = np.array([r.stats.get("scene_time", 0.0) for r in ok]) * 1e3
        rrt = np.array([r.stats.get("planner_planning_time", np.nan) for r in ok]) * 1e3
        out.append(
            {
                "scene": scene,
                "queries": len(results),
                "solved": len(ok),
                "obstacles": int(np.median(sizes[scene])),
                "ms_median": _med(total),
                "ms_p95": _p95(total),
                "scene_ms_median": _med(build),
                "planner_ms_median": _med(rrt),
            }
        )
    return out


def _med(a: np.ndarray) -> float | None:
    a = a[np.isfinite(a)]
    return round(float(np.median(a)), 2) if len(a) else None


def _p95(a: np.ndarray) -> float | None:
    a = a[np.isfinite(a)]
    return round(float(np.percentile(a, 95)), 2) if len(a) else None
