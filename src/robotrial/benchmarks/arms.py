"""`robotrial bench arms`: every arm of PyPI's example-robot-data, as a buyer would try it
(layer 5).

No arm here was written or tuned for robotrial. For each one, its URDF and the files it
names are zipped as a package (folders as in the corpus, so the `package://` names are
one or two folders off, as a user's zip often is) and:

1. uploaded through the page's route (`POST /api/robots/upload`) to a server that has
   warmed its planner as `robotrial serve` does, with an empty robot cache; its first
   PlanTask request is timed through the planning node, so the time includes building
   its sphere model and self-collision pairs;
2. loaded as `--robot FILE` reads it (`cli/robot_source.py`); its tool, arm group and
   joints must equal the upload's;
3. asked `--goals` positions (reached by forward kinematics from random collision-free
   configurations on the start's side of the planner's walls, joint ranges no path
   crosses) from one free start, standing in the page's desk world, without and
   then with two random boxes (placed clear of the start and of the configuration that
   reached the goal); each request is answered in process by the uploaded robot's
   TaskPlanner and timed;
4. every path is checked densely with MuJoCo (every 0.005 rad of the tracked
   trajectory): against the planner's rules (the pairs its matrix enables, and the
   world), and strictly (every link pair but rigid, adjacent and zero-pose ones).

Arms that cannot be planned as one group, and robots of the corpus that are not arms,
are named with the reason. Writes a table per arm to `--md` and JSON to `-o` only when
asked.
"""

from __future__ import annotations

import argparse
import io
import os
import platform
import statistics
import tempfile
import time
import warnings
import zipfile
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from robotrial.console import (
    add_json_flag,
    console,
    print_json,
    print_table,
    progress,
    write_result,
)

HELP = "every arm of example-robot-data uploaded and planned: solved, colliding, times"
STEP = 0.005  # rad (or m): the dense check's step along a trajectory
BOX_SIZES = (0.05, 0.25)  # m: a random box's edges are drawn in this range
LATER_MS = 50.0  # ms: what a later plan should take at most, in process
STARTS_TRIED = 2000  # random configurations drawn for a free start and free goals

# (name, URDF under the corpus's robots folder, what is planned)
ARMS: tuple[tuple[str, str, str], ...] = (
    ("UR3", "ur_description/urdf/ur3_robot.urdf", ""),
    ("UR5", "ur_description/urdf/ur5_robot.urdf", ""),
    ("UR10", "ur_description/urdf/ur10_robot.urdf", ""),
    ("Panda", "panda_description/urdf/panda.urdf", ""),
    ("Kinova Jaco 2", "kinova_description/robots/kinova.urdf", ""),
    ("xArm 7", "xarm_description/urdf/xarm7.urdf", ""),
    ("Unitree Z1", "z1_description/urdf/z1.urdf", ""),
    ("SO-100", "so_arm_description/urdf/so100.urdf", ""),
    ("SO-101", "so_arm_description/urdf/so101.urdf", ""),
    ("Tiago", "tiago_description/robots/tiago.urdf", "torso lift and the arm"),
    ("Tiago Pro", "tiago_pro_description/robots/tiago_pro.urdf", "torso lift and left arm"),
    ("Baxter", "baxter_description/urdf/baxter.urdf", "right arm; the left one alike"),
    ("PR2", "pr2_description/urdf/pr2.urdf", "torso lift and right arm"),
    ("Talos", "talos_data/robots/talos_reduced.urdf", "torso and left arm, legs fixed"),
    ("ANYmal + Kinova", "anymal_b_simple_description/robots/anymal-kinova.urdf", "the arm"),
    ("B1 + Z1", "b1_description/urdf/b1-z1.urdf", "the arm, legs fixed"),
    ("Centauro", "centauro_description/urdf/centauro.urdf", "torso yaw and left arm"),
)

# the corpus's other robots, and why none of them is benchmarked as an arm
NOT_ARMS: tuple[tuple[str, str], ...] = (
    (
        "a1, anymal, anymal_c, b1, bolt, go1, go2, hyq, laikago, quadruped, solo, solo12",
        "legged robots: their chains are legs (2-3 joints each), no arm",
    ),
    ("alexander (lower body), cassie", "legs only"),
    (
        "alex, g1, icub, romeo, simple_humanoid, talos_full_v2, human",
        "humanoids: an arm hangs from a free-floating pelvis (with legs that would have to "
        "balance it); Talos stands for them with its legs held fixed",
    ),
    ("allegro_hand", "a hand: four fingers of four joints, each a chain of its own"),
    ("finger_edu", "one finger of three joints (named as fingers), no arm"),
    ("double_pendulum, asr_twodof", "two-joint planar mechanisms, not arms"),
    ("borinot, hextilt", "flying arms: the arm's base is a drone in flight"),
    ("hector, iris", "drones, no joints to plan"),
    (
        "tiago_dual, tiago_no_hand, panda_collision, talos variants, ur joint-limited and "
        "gripper variants",
        "variants of arms above: the same chain",
    ),
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--arms", nargs="+", metavar="NAME", help="only these arms (names as in the table)"
    )
    parser.add_argument("--goals", type=int, default=20, help="goals per arm and setting")
    parser.add_argument("--seed", type=int, default=0, help="random seed of goals and boxes")
    parser.add_argument("--time-limit", type=float, default=0.0, help="s per plan (0: default)")
    parser.add_argument("--md", type=Path, metavar="MD", help="write the tables here")
    parser.add_argument("-o", "--output", type=Path, metavar="JSON", help="write JSON here")
    add_json_flag(parser)


@dataclass
class Request:
    """One goal: its setting, the outcome, the times and the dense checks' findings."""

    setting: str
    goal: list[float]
    solved: bool = False
    failure: str = ""
    message: str = ""
    seconds: float = 0.0
    cpu_seconds: float = 0.0  # the process's CPU time: what an idle core would take
    colliding: str = ""  # the planner's rules: what the path touches, "" if nothing
    strict: str = ""  # any link pair but rigid, adjacent and zero-pose ones


@dataclass
class ArmResult:
    """What one arm did."""

    name: str
    file: str
    planned: str = ""
    tool: str = ""
    joints: list[str] = field(default_factory=list)
    refused: str = ""  # why it could not be benchmarked, if it could not
    upload_s: float = 0.0
    first_plan_s: float = 0.0
    first_plan_cpu_s: float = 0.0  # the process's CPU time: what an idle core would take
    first_plan_file_s: float = 0.0
    pairs_checked: int = 0
    past_walls: int = 0  # goals drawn again: past a joint range no path crosses
    pairs_left_out: dict[str, int] = field(default_factory=dict)
    requests: list[Request] = field(default_factory=list)

    def solved(self, setting: str) -> int:
        return sum(r.solved for r in self.requests if r.setting == setting)

    def asked(self, setting: str) -> int:
        return sum(r.setting == setting for r in self.requests)

    def later_median_ms(self, setting: str) -> float:
        times = [r.seconds for r in self.requests if r.setting == setting and r.solved]
        return 1e3 * statistics.median(times) if times else float("nan")

    def later_max_ms(self, setting: str) -> float:
        return 1e3 * max((r.seconds for r in self.requests if r.setting == setting), default=0.0)

    def later_over(self, limit_s: float, cpu: bool = False) -> int:
        """How many later plans took over `limit_s` (of the process's CPU with `cpu`)."""
        return sum((r.cpu_seconds if cpu else r.seconds) > limit_s for r in self.requests)


def corpus_root() -> Path:
    """The robots folder the example-robot-data wheel installs."""
    from importlib.metadata import PackageNotFoundError, distribution

    try:
        dist = distribution("example-robot-data")
    except PackageNotFoundError:
        raise SystemExit("robotrial bench arms: pip install example-robot-data") from None
    return Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots")))


def package_zip(urdf: Path, root: Path) -> bytes:
    """The URDF and every file it names, zipped with their paths under `root` (the
    corpus's robots folder): a package as a user would zip it."""
    from robotrial.geometry import Mesh
    from robotrial.model import load_robot

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = load_robot(urdf)
    files = {urdf}
    for link in model.links:
        for part in (*link.visuals, *link.collisions):
            if isinstance(part.geometry, Mesh):
                files.add(Path(part.geometry.filename))
    files |= {Path(m.texture) for m in model.materials.values() if m.texture}
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
        for f in sorted(files):
            z.write(f, str(f.resolve().relative_to(root.resolve())))
    return out.getvalue()


def _free_configurations(planner, rng: np.random.Generator, n: int) -> np.ndarray:
    """Up to `n` configurations free under the planner's checks and MuJoCo's, in its
    world."""
    from robotrial.collision.exact import ExactChecker
    from robotrial.collision.sphere_model import CollisionChecker

    checker = CollisionChecker(planner.spheres, planner.world_env, planner.padding)
    exact = ExactChecker(checker, planner.world)
    qs = planner.kin.random(rng, STARTS_TRIED)
    qs = qs[checker.valid(qs)]
    free = [q for q in qs[: 4 * n] if exact.valid(q)]
    return np.array(free[:n]).reshape(-1, planner.kin.d)


def _reachable_goals(planner, rng, free: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, int]:
    """The start (the first of `free`) and up to `n` goal configurations on its side of
    the planner's walls (`CollisionChecker.walls`: joint ranges no path crosses), those
    past a wall drawn again; and how many were."""
    from robotrial.collision.sphere_model import CollisionChecker

    checker = CollisionChecker(planner.spheres, planner.world_env, planner.padding)
    start, reached = free[0], free[1:]
    past = checker.beyond_walls(start, reached)
    reached, dropped = reached[~past], int(past.sum())
    for _ in range(5):
        if len(reached) >= n or not dropped:
            break
        more = _free_configurations(planner, rng, n)
        reached = np.vstack([reached, more[~checker.beyond_walls(start, more)]])
    return start, reached[:n], dropped


def _boxes(planner, rng, configurations, region) -> list:
    """Two random boxes in `region` (low and high corners) that the planner's spheres
    find clear of every configuration given (so MuJoCo's shapes are clear too), or fewer
    if none fits in 200 draws."""
    from robotrial.collision.sphere_model import CollisionChecker, Environment
    from robotrial.geometry import Box, Pose

    boxes: list = []
    for _ in range(200):
        if len(boxes) == 2:
            break
        candidate = (
            f"box{len(boxes) + 1}",
            Box(tuple(float(v) for v in rng.uniform(*BOX_SIZES, 3))),  # type: ignore[arg-type]
            Pose(tuple(float(v) for v in rng.uniform(region[0], region[1]))),  # type: ignore[arg-type]
        )
        env = Environment()
        env.add(*candidate)
        if np.all(CollisionChecker(planner.spheres, env, planner.padding).valid(configurations)):
            boxes.append(candidate)
    return boxes


def _dense_checks(planner, result, obstacles, strict_pairs) -> tuple[str, str]:
    """What the path touches, densely: by the planner's rules, and strictly ("" for
    nothing)."""
    from robotrial.collision.exact import ExactChecker

    qs = result.trajectory.tracked(0.05)
    found = []
    for pairs in (None, strict_pairs):
        exact = ExactChecker(result.checker, planner.world, obstacles, robot_pairs=pairs)
        ok, index = exact.path_valid(qs, step=STEP)
        if ok:
            found.append("")
            continue
        # the first touching sample lies between two rows of qs: name what the row after
        # it touches, or say it was between them
        near = qs[min(index // 2 + 1, len(qs) - 1)] if index >= 0 else qs[-1]
        touching = sorted({" / ".join(c) for c in exact.contacts(near)})
        found.append("; ".join(touching) or "a contact between the trajectory's samples")
    return found[0], found[1]


def _strict_pairs(spheres) -> set[tuple[str, str]]:
    """Every pair of robot bodies but those no motion can bring into contact (rigid,
    adjacent) or touching already at the zero pose, both ways round."""
    names = [b.name for b in spheres.bodies]
    loose = {k for k, why in spheres.reasons.items() if why in ("rigid", "adjacent", "default")}
    out = {(a, b) for i, a in enumerate(names) for b in names[i + 1 :] if (a, b) not in loose}
    return out | {(b, a) for a, b in out}


def bench_arm(name: str, rel: str, planned: str, root: Path, args, server) -> ArmResult:
    """Upload, load, plan and check one arm on `server` (see the module doc)."""
    from robotrial.cli.robot_source import load_robot_from_args
    from robotrial.kinematics.chain import Kinematics
    from robotrial.msgs.geometry_msgs import Point, Quaternion
    from robotrial.msgs.geometry_msgs import Pose as PoseMsg
    from robotrial.msgs.robotrial_msgs import PlanTaskRequest
    from robotrial.msgs.sensor_msgs import JointState
    from robotrial.planning.task import TaskPlanner, TaskRequest
    from robotrial.ros.planning_node import robot_service

    client, bus, catalog, cache = server
    urdf = root / rel
    out = ArmResult(name, rel, planned)
    rng = np.random.default_rng(args.seed)
    os.environ["ROBOTRIAL_CACHE"] = str(cache / name.replace(" ", "_"))  # empty: fresh
    data = package_zip(urdf, root)
    t = time.perf_counter()
    r = client.post("/api/robots/upload", files={"file": (f"{urdf.stem}.zip", data)})
    out.upload_s = time.perf_counter() - t
    if r.status_code != 201:
        out.refused = f"upload refused ({r.status_code}): {r.json()['detail']}"
        return out
    entry = r.json()["robot"]
    model, world = catalog.robot(entry["name"]), catalog.world(entry["world"])
    out.tool = model.end_effector
    kin = Kinematics(model)
    out.joints = list(kin.joint_names)
    file_model = load_robot_from_args(
        argparse.Namespace(robot=str(urdf), package_path=[], xacro_arg=[], tool="")
    )
    if (file_model.end_effector, Kinematics(file_model).joint_names) != (out.tool, out.joints):
        out.refused = "--robot FILE finds another tool or arm than the upload"
        return out

    # the first request builds the planner (spheres, pairs): from the zero pose to where
    # a random configuration puts the tool, as the page would ask it
    start = np.clip(np.zeros(kin.d), kin.lower, kin.upper)
    first = kin.link_pose(kin.random(rng, 1)[0])[:3, 3]
    request = PlanTaskRequest(
        current_joints=JointState(name=out.joints, position=[float(v) for v in start]),
        ee_goal=PoseMsg(Point(*map(float, first)), Quaternion(0.0, 0.0, 0.0, 0.0)),
        time_limit=args.time_limit,
    )
    t, cpu = time.perf_counter(), time.process_time()
    bus.call(robot_service(entry["name"]), request)
    out.first_plan_s = time.perf_counter() - t
    out.first_plan_cpu_s = time.process_time() - cpu
    t = time.perf_counter()
    TaskPlanner(file_model, world).plan(
        TaskRequest(start, first, joint_names=out.joints, time_limit=args.time_limit), seed=0
    )
    out.first_plan_file_s = time.perf_counter() - t

    planner = bus.node("/robotrial_planner").planner_for(entry["name"])
    reasons = list(planner.spheres.reasons.values())
    out.pairs_left_out = {why: reasons.count(why) for why in sorted(set(reasons))}
    n_bodies = len(planner.spheres.bodies)
    out.pairs_checked = n_bodies * (n_bodies - 1) // 2 - len(reasons)
    free = _free_configurations(planner, rng, args.goals + 1)
    if len(free) < 2:
        out.refused = f"fewer than 2 free configurations in {STARTS_TRIED} draws"
        return out
    start, reached, out.past_walls = _reachable_goals(planner, rng, free, args.goals)
    goals = kin.link_pose(reached)[:, :3, 3]
    strict = _strict_pairs(planner.spheres)
    region = (goals.min(axis=0), goals.max(axis=0))
    for setting in ("free", "boxes"):
        for k, goal in enumerate(goals):
            obstacles = (
                _boxes(planner, rng, np.stack([start, reached[k]]), region)
                if setting == "boxes"
                else []
            )
            task = TaskRequest(
                start, goal, joint_names=out.joints, obstacles=obstacles, time_limit=args.time_limit
            )
            t, cpu = time.perf_counter(), time.process_time()
            res = planner.plan(task, seed=args.seed + k)
            req = Request(setting, [float(v) for v in goal], res.success, res.failure)
            req.message, req.seconds = res.message, time.perf_counter() - t
            req.cpu_seconds = time.process_time() - cpu
            if res.success:
                req.colliding, req.strict = _dense_checks(planner, res, obstacles, strict)
            out.requests.append(req)
    return out


def run(args: argparse.Namespace) -> int:
    root = corpus_root()
    chosen = [a for a in ARMS if not args.arms or a[0] in args.arms]
    if args.arms and len(chosen) != len(args.arms):
        known = ", ".join(a[0] for a in ARMS)
        raise SystemExit(f"robotrial bench arms: unknown arm in {args.arms}; known: {known}")
    from fastapi.testclient import TestClient

    from robotrial.app.server import create_app
    from robotrial.ros.bus import Bus

    load = os.getloadavg()[0]
    results: list[ArmResult] = []
    bus = Bus()
    kept = os.environ.get("ROBOTRIAL_CACHE")
    with tempfile.TemporaryDirectory() as scratch, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        folder = Path(scratch)
        os.environ["ROBOTRIAL_CACHE"] = str(folder / "server")
        app = create_app(bus=bus, planner=True, uploads_dir=folder / "uploads")
        with TestClient(app, base_url="http://127.0.0.1") as client:
            # as a served page: the planner's kernels compiled before anyone uploads
            while client.get("/api/config").json()["planner"] != "ready":
                time.sleep(0.5)
            server = (client, bus, app.state.catalog, folder)
            with progress("arms", len(chosen), enabled=not args.json) as advance:
                for name, rel, planned in chosen:
                    try:
                        results.append(bench_arm(name, rel, planned, root, args, server))
                    except Exception as exc:  # named in the table; the others still run
                        results.append(
                            ArmResult(name, rel, planned, refused=f"{type(exc).__name__}: {exc}")
                        )
                    write(args, results, load)
                    advance()
    if kept is None:
        os.environ.pop("ROBOTRIAL_CACHE", None)
    else:
        os.environ["ROBOTRIAL_CACHE"] = kept
    report = write(args, results, load)
    if args.json:
        print_json(report)
        return 0
    print_table("arms", COLUMNS, [row(r) for r in results])
    for r in results:
        for line in failures(r):
            console.print(f"{r.name}: {line}", markup=False, highlight=False)
    return 0


def write(args: argparse.Namespace, results: list[ArmResult], load: float) -> dict[str, Any]:
    """The report so far, written where `--md` and `-o` say (after every arm, so that a
    long run stopped halfway keeps what it measured)."""
    report = {
        "machine": {"cpus": os.cpu_count(), "platform": platform.platform()},
        "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
        "load_start": load,
        "load_end": os.getloadavg()[0],
        "goals": args.goals,
        "seed": args.seed,
        "time_limit": args.time_limit,
        "arms": [asdict(r) for r in results],
        "not_arms": [list(x) for x in NOT_ARMS],
    }
    write_result(report, args.output)
    if args.md:
        args.md.parent.mkdir(parents=True, exist_ok=True)
        args.md.write_text(markdown(results, report))
    return report


COLUMNS = (
    "arm",
    "joints",
    "tool",
    "solved free",
    "solved boxes",
    "colliding",
    "strict contacts",
    "upload s",
    "first plan s",
    "first plan CPU s",
    "first plan (file) s",
    "later median ms free",
    "later median ms boxes",
    "later max ms free",
    "later max ms boxes",
    f"later over {LATER_MS:.0f} ms (CPU)",
)


def row(r: ArmResult) -> list[Any]:
    if r.refused:
        return [r.name, *([""] * (len(COLUMNS) - 2)), r.refused[:80]]
    colliding = sum(bool(q.colliding) for q in r.requests)
    strict = sum(bool(q.strict) for q in r.requests)
    return [
        r.name,
        len(r.joints),
        r.tool,
        f"{r.solved('free')}/{r.asked('free')}",
        f"{r.solved('boxes')}/{r.asked('boxes')}",
        colliding,
        strict,
        f"{r.upload_s:.1f}",
        f"{r.first_plan_s:.1f}",
        f"{r.first_plan_cpu_s:.1f}",
        f"{r.first_plan_file_s:.1f}",
        f"{r.later_median_ms('free'):.0f}",
        f"{r.later_median_ms('boxes'):.0f}",
        f"{r.later_max_ms('free'):.0f}",
        f"{r.later_max_ms('boxes'):.0f}",
        f"{r.later_over(LATER_MS / 1e3)} ({r.later_over(LATER_MS / 1e3, cpu=True)})",
    ]


def failures(r: ArmResult) -> list[str]:
    """Each unsolved request and each touching path, in words."""
    out = []
    for k, q in enumerate(r.requests):
        goal = ", ".join(f"{v:.2f}" for v in q.goal)
        k %= max(r.asked(q.setting), 1)
        if not q.solved:
            out.append(f"{q.setting} #{k} ({goal}): {q.message}")
        if q.colliding:
            out.append(f"{q.setting} #{k} path touches (planner's rules): {q.colliding}")
        if q.strict and not q.colliding:
            out.append(f"{q.setting} #{k} path touches a pair the matrix leaves out: {q.strict}")
    return out


def markdown(results: list[ArmResult], report: dict[str, Any]) -> str:
    """docs/benchmarks/arms.md from a run."""
    lines = [
        "# Arms nobody here wrote: example-robot-data",
        "",
        f"Measured {report['date']} on {report['machine']['platform']}, "
        f"{report['machine']['cpus']} cores shared with other jobs (load average "
        f"{report['load_start']:.1f} at the start, {report['load_end']:.1f} at the end), by "
        f"`robotrial bench arms --goals {report['goals']} --seed {report['seed']}"
        + (f" --time-limit {report['time_limit']:g}" if report["time_limit"] else "")
        + "`. "
        "Times under that load are several times what a quiet machine gives; compare "
        "them with each other, not with a target.",
        "",
        "Each arm's URDF and meshes are zipped as a package, uploaded through the page's "
        "route to a fresh server (empty robot cache) and loaded as `--robot FILE` does; "
        f"{report['goals']} goal positions reached by forward kinematics from random "
        "collision-free configurations (those past a wall of the planner's, a joint range "
        "no path crosses, drawn again and counted per arm) "
        "are planned from one free start in the desk world, "
        "without and then with two random boxes. Every path is checked with MuJoCo every "
        f"{STEP} rad: *colliding* by the planner's rules, *strict* counting every link "
        "pair but rigid, adjacent and zero-pose ones (pairs the self-collision matrix "
        "leaves out as always or never touching are counted there). Later plans are the "
        "requests after an arm's first, timed in process: their median and slowest, and how "
        f"many took over {LATER_MS:.0f} ms (in brackets: over {LATER_MS:.0f} ms of the "
        "process's CPU, what an idle core would take).",
        "",
        "| " + " | ".join(COLUMNS) + " |",
        "| " + " | ".join("---" for _ in COLUMNS) + " |",
    ]
    lines += ["| " + " | ".join(str(c) for c in row(r)) + " |" for r in results]
    lines += ["", "## Per arm", ""]
    for r in results:
        lines.append(f"### {r.name}")
        lines.append("")
        lines.append(f"`{r.file}`" + (f", planned: {r.planned}" if r.planned else ""))
        if r.refused:
            lines += ["", f"Not benchmarked: {r.refused}", ""]
            continue
        left = ", ".join(f"{n} {why}" for why, n in r.pairs_left_out.items())
        lines += [
            "",
            f"Tool `{r.tool}`; joints {', '.join(r.joints)}. Self-collision pairs checked: "
            f"{r.pairs_checked}; left out: {left}."
            + (
                f" Goals drawn again because no path reaches them (past a wall): {r.past_walls}."
                if r.past_walls
                else ""
            ),
            "",
        ]
        named = failures(r)
        lines += [f"- {line}" for line in named] if named else ["- no failures"]
        lines.append("")
    lines += ["## Robots of the corpus not benchmarked as arms", ""]
    lines += [f"- {who}: {why}" for who, why in NOT_ARMS]
    lines.append("")
    return "\n".join(lines)
