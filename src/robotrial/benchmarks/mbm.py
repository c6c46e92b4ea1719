"""MotionBenchMaker's Panda problems: `robotrial bench planning --suite mbm` (layer 5).

The seven Panda scenes of MotionBenchMaker (bookshelf small/tall/thin, box, cage, table
pick, table under pick; 100 problems each), as VAMP publishes them inside its source
distribution on PyPI (Apache-2.0). The data is fetched at benchmark time from the package
index and cached outside the repository (`$XDG_CACHE_HOME/robotrial/mbm`, else
~/.cache/robotrial/mbm). Each scene YAML is a MoveIt PlanningScene (boxes, cylinders,
spheres), each request a MotionPlanRequest (start joints, goal joint constraints). Our
RRTConnect and OMPL's RRTConnect with the MuJoCo check solve the same problems on the
Panda of example-robot-data; every path is checked densely with MuJoCo.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import tarfile
import tempfile
import time
import urllib.request
from datetime import date
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from robotrial.cache import cache_dir as shared_cache
from robotrial.geometry import Box, Cylinder, Pose, Shape, Sphere

VAMP_SDIST = "vamp-planner==0.6.4"
PROBLEMS_MEMBER = "resources/panda/problems.tar.bz2"
SCENES = [
    "bookshelf_small",
    "bookshelf_tall",
    "bookshelf_thin",
    "box",
    "cage",
    "table_pick",
    "table_under_pick",
]
# VAMP's published figure (README of vamp-planner 0.6.4): RRTConnect over all seven Panda
# scenes, median 35 us on one core of a consumer desktop PC; no per-scene figure found
VAMP_MEDIAN_US = 35.0
# VAMP 0.6.4 built from its source distribution on a 2-core AMD EPYC (Zen 3, AVX2) of the
# kind these benchmarks run on, its own scripts/evaluate_mbm.py (RRTConnect, one thread,
# range 1.0), four runs at a load average of about 2: per scene, the lowest and highest
# median and p95 in microseconds. Its timer leaves out the start and goal checks.
VAMP_HERE_US = {
    "bookshelf_small": (55, 91, 942, 1344),
    "bookshelf_tall": (59, 82, 257, 379),
    "bookshelf_thin": (61, 106, 288, 397),
    "box": (115, 202, 294, 503),
    "cage": (342, 566, 1492, 2427),
    "table_pick": (43, 79, 102, 183),
    "table_under_pick": (86, 148, 196, 339),
}
FINGERS = {"panda_finger_joint1": 0.04, "panda_finger_joint2": 0.04}
GRIPPER_LINKS = {"panda_leftfinger", "panda_rightfinger", "panda_hand"}


HELP = "MotionBenchMaker's Panda problems: our RRTConnect vs OMPL's with MuJoCo, per scene"


def add_suite_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of the suite itself (also taken by `bench planning --suite mbm`)."""
    parser.add_argument(
        "--problems", type=int, default=100, help="problems per MotionBenchMaker scene (1-100)"
    )
    parser.add_argument("--scenes", nargs="+", help="MotionBenchMaker scenes (default: all)")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_suite_arguments(parser)
    parser.add_argument("--time-limit", type=float, default=10.0, help="s per problem")
    parser.add_argument("--no-ompl", action="store_true", help="skip the OMPL baseline")
    parser.add_argument("-o", "--output", type=Path, help="write the results as JSON here")
    parser.add_argument(
        "--md",
        type=Path,
        default=None,
        help="write the results as Markdown here (e.g. docs/benchmarks/mbm.md)",
    )
    parser.add_argument(
        "--plot",
        type=Path,
        metavar="PNG",
        help="write the distribution of solve times per scene (ours, OMPL) as a PNG here",
    )
    parser.add_argument("--json", action="store_true", help="print the results as JSON")


class MbmError(RuntimeError):
    """The problem set cannot be had or read (says what and where)."""


def cache_dir() -> Path:
    """Where the MotionBenchMaker problems are kept once downloaded."""
    return shared_cache("mbm")


def fetch(cache: Path | None = None) -> Path:
    """The folder of the Panda problems (one sub-folder per scene), downloaded once."""
    cache = cache or cache_dir()
    problems = cache / "problems"
    if (problems / "box_panda").is_dir():
        return problems
    cache.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        sdist = _download_sdist(Path(tmp))
        with tarfile.open(sdist) as outer:
            member = next((m for m in outer.getmembers() if m.name.endswith(PROBLEMS_MEMBER)), None)
            if member is None:
                raise MbmError(f"{sdist.name} holds no {PROBLEMS_MEMBER}")
            inner = outer.extractfile(member)
            assert inner is not None
            with tarfile.open(fileobj=inner, mode="r:bz2") as tar:
                tar.extractall(cache, filter="data")
    if not (problems / "box_panda").is_dir():
        raise MbmError(f"{PROBLEMS_MEMBER} did not unpack into {problems}")
    return problems


def _download_sdist(folder: Path) -> Path:
    """VAMP's source distribution from the package index's JSON listing (PEP 691), its
    sha256 checked. Not `pip download`: pip would build the package's build
    dependencies (CMake among them) from source only to read its metadata."""
    name, version = VAMP_SDIST.split("==")
    index = os.environ.get("PIP_INDEX_URL", "https://pypi.org/simple").rstrip("/")
    wanted = f"{name.replace('-', '_')}-{version}.tar.gz"
    listing_url = f"{index}/{name}/"
    try:
        request = urllib.request.Request(
            listing_url, headers={"Accept": "application/vnd.pypi.simple.v1+json"}
        )
        with urllib.request.urlopen(request, timeout=60) as answer:
            files = json.load(answer)["files"]
        entry = next((f for f in files if f["filename"] == wanted), None)
        if entry is None:
            raise MbmError(f"{listing_url} lists no {wanted}")
        target = folder / wanted
        digest = hashlib.sha256()
        with urllib.request.urlopen(entry["url"], timeout=60) as answer, target.open("wb") as out:
            while chunk := answer.read(1 << 20):
                digest.update(chunk)
                out.write(chunk)
    except (OSError, ValueError, KeyError) as exc:
        raise MbmError(f"could not download {wanted} from {listing_url}: {exc}") from None
    expected = entry.get("hashes", {}).get("sha256")
    if expected and digest.hexdigest() != expected:
        raise MbmError(f"{wanted} from {entry['url']}: sha256 {digest.hexdigest()} != {expected}")
    return target


def _pose(p: dict[str, Any]) -> Pose:
    return Pose(tuple(map(float, p["position"])), tuple(map(float, p["orientation"])))  # type: ignore[arg-type]


def _shape(prim: dict[str, Any], where: str) -> Shape:
    kind, dims = str(prim.get("type", "")).lower(), [float(v) for v in prim["dimensions"]]
    if kind in ("box", "1"):
        return Box((dims[0], dims[1], dims[2]))
    if kind in ("cylinder", "3"):  # MoveIt: height, radius
        return Cylinder(radius=dims[1], length=dims[0])
    if kind in ("sphere", "2"):
        return Sphere(dims[0])
    raise MbmError(f"{where}: primitive type {prim.get('type')!r} is not a box, cylinder or sphere")


def read_scene(path: Path) -> list[tuple[str, Shape, Pose]]:
    """The obstacles of a MoveIt PlanningScene YAML (world.collision_objects)."""
    data = yaml.safe_load(Path(path).read_text())
    out = []
    objects = ((data or {}).get("world") or {}).get("collision_objects") or []
    for i, ob in enumerate(objects):
        name = str(ob.get("id") or f"object{i}")
        base = _pose(ob["pose"]) if "pose" in ob else Pose()
        for k, (prim, pose) in enumerate(
            zip(ob.get("primitives") or [], ob.get("primitive_poses") or [], strict=True)
        ):
            where = f"{path}: collision_objects[{i}] ({name}) primitive {k}"
            out.append((f"{name}_{k}" if k else name, _shape(prim, where), base @ _pose(pose)))
    return out


def read_request(path: Path, joints: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """Start and goal of a MotionPlanRequest YAML, over `joints` (by name)."""
    data = yaml.safe_load(Path(path).read_text())
    state = data["start_state"]["joint_state"]
    start = dict(zip(state["name"], state["position"], strict=True))
    goal = {
        c["joint_name"]: c["position"]
        for c in data["goal_constraints"][0]["joint_constraints"]  # one goal per request
    }
    missing = [j for j in joints if j not in start or j not in goal]
    if missing:
        raise MbmError(f"{path}: the request gives no start or goal for {missing}")
    return np.array([start[j] for j in joints], float), np.array([goal[j] for j in joints], float)


def problems(folder: Path, scene: str, count: int, robot, spheres=None) -> list[Any]:
    """The first `count` problems of `scene` as PlanningProblems for `robot` (the Panda)."""
    from robotrial.collision.sphere_model import CollisionChecker
    from robotrial.kinematics.chain import Kinematics
    from robotrial.model.world import Floor, World
    from robotrial.planning.problems import PlanningProblem
    from robotrial.planning.task import robot_spheres

    # the fingers open (the requests' own 0.065 m is past the Panda's 0.04 m limit), as
    # MBM's grasp goals around the objects need them
    kin = spheres.kin if spheres is not None else Kinematics(robot, fixed=FINGERS)
    spheres = spheres or robot_spheres(kin, fine=True)  # kept on disk: seconds to make
    # MBM's tables stand below the robot's base: no floor at z = 0
    world = World(name="mbm", floor=Floor(height=-5.0))
    where = folder / f"{scene}_panda"
    out = []
    for k in range(1, count + 1):
        obstacles = read_scene(where / f"scene{k:04d}.yaml")
        start, goal = read_request(where / f"request{k:04d}.yaml", kin.joint_names)
        env = _environment(obstacles)
        # a pick goal closes the hand around its object: as MoveIt's allowed collisions
        # let the fingers touch it there, the object the gripper's spheres reach at the
        # goal leaves the scene (counted in the report) when no other link touches anything
        checker = CollisionChecker(spheres, env)
        near = checker.contacts(goal, fine=False)
        grasped = {ob for link, ob in near if link in GRIPPER_LINKS}
        touched = checker.contacts(goal, fine=True)
        if grasped and all(link in GRIPPER_LINKS for link, _ in touched):
            obstacles = [o for o in obstacles if o[0] not in grasped]
            env = _environment(obstacles)
        else:
            grasped = set()
        out.append(
            PlanningProblem(
                f"{scene}/{k}", f"MotionBenchMaker {scene} #{k}" + (
                    f" (grasped {', '.join(sorted(grasped))} left out)" if grasped else ""
                ), robot, kin, spheres,
                obstacles, start, goal, world, env,
            )
        )  # fmt: skip
    return out


def _environment(obstacles: list[tuple[str, Shape, Pose]]):
    from robotrial.collision.sphere_model import Environment

    env = Environment()
    for name, shape, pose in obstacles:
        env.add(name, shape, pose)
    return env


def _stats(times: list[float]) -> dict[str, float | None]:
    if not times:
        return {"median_ms": None, "p95_ms": None}
    t = 1e3 * np.array(times)
    return {"median_ms": float(np.median(t)), "p95_ms": float(np.percentile(t, 95))}


def run_scene(probs: list[Any], time_limit: float, ompl: bool, on_problem=None) -> dict[str, Any]:
    """Ours and OMPL's RRTConnect on each problem once; paths checked densely by MuJoCo.

    Ours is timed twice. Back to back, as VAMP's evaluate_mbm.py times its planner: the
    scene's queries one after the other, each on its checker built beforehand (VAMP builds
    its environment outside its timer), nothing else run between them. Then cold, as a
    request answered after other work: each query right after MuJoCo's dense check of the
    last path and the previous problem's other planners. Both timers include the start
    and goal checks. Ours also runs as OMPL's RRTConnect (its alternation of the trees, no
    dynamic domains, its range) on the same checks, which splits the speed-up into what
    the checks give and what the planner's refinements give."""
    from robotrial.benchmarks.planning import _ompl
    from robotrial.planning.base import Problem, default_range
    from robotrial.planning.rrt_connect import RRTConnect

    ours = RRTConnect()
    # OMPL's RRTConnect on our checks: its alternation of the trees and its default range
    ompl_range = default_range(probs[0].checker()) if probs else 0.0
    alternating = RRTConnect(ompl_range, balance=False, dynamic_domain=False, unstick=False)
    ours_t, cpu_t, cold_t, alt_t, ompl_t, rows = [], [], [], [], [], []
    if probs:  # untimed: numba compiles (or loads its cache) on the first call
        ours.solve(Problem(probs[0].start, probs[0].goal[None], 0.05, 0), probs[0].checker())
    checkers = [prob.checker() for prob in probs]
    queries = [Problem(p.start, p.goal[None], time_limit, k) for k, p in enumerate(probs)]
    warm = []  # back to back: (result, CPU seconds)
    for problem, checker in zip(queries, checkers, strict=True):
        cpu = time.thread_time()
        res = ours.solve(problem, checker)
        warm.append((res, time.thread_time() - cpu))
    for prob, problem, (res, cpu) in zip(probs, queries, warm, strict=True):
        checker = prob.checker()  # new, as the back-to-back query's has learnt its order
        exact = prob.exact(checker)
        start_ok, goal_ok = exact.valid(prob.start), exact.valid(prob.goal)
        colliding = bool(res.success and not exact.path_valid(res.path)[0])
        cold_cpu = time.thread_time()
        cold = ours.solve(problem, checker)
        cold_cpu = time.thread_time() - cold_cpu
        alt = alternating.solve(problem, checker)
        row: dict[str, Any] = {
            "problem": prob.name,
            "valid_ends_mujoco": bool(start_ok and goal_ok),
            "ours_solved": bool(res.success),
            "ours_ms": 1e3 * res.planning_time,
            "ours_cpu_ms": 1e3 * cpu,
            "ours_cold_cpu_ms": 1e3 * cold_cpu,
            "ours_iterations": int(res.stats.get("iterations", 0)),
            "ours_nodes": int(res.stats.get("nodes", 0)),
            "ours_colliding": colliding
            or bool(cold.success and not exact.path_valid(cold.path)[0]),
            "alternating_solved": bool(alt.success),
            "alternating_ms": 1e3 * alt.planning_time,
        }
        if res.success:
            ours_t.append(res.planning_time)
            cpu_t.append(cpu)
        if cold.success:
            cold_t.append(cold_cpu)
        if alt.success:
            alt_t.append(alt.planning_time)
        if ompl and start_ok and goal_ok:  # else OMPL would wait out its time limit
            o = _ompl(prob, exact, "rrt_connect", 1, time_limit, time_limit)
            row.update(
                ompl_solved=o["success"] > 0,
                ompl_ms=1e3 * o["median_s"],
                ompl_colliding=o["invalid_paths"] > 0,
            )
            if o["success"] > 0:
                ompl_t.append(o["median_s"])
        rows.append(row)
        if on_problem is not None:
            on_problem()
    out: dict[str, Any] = {
        "problems": len(rows),
        "ours": {"solved": len(ours_t), **_stats(ours_t)},
        "ours_cpu": _stats(cpu_t),
        "ours_cold_cpu": {"solved": len(cold_t), **_stats(cold_t)},
        "alternating": {"solved": len(alt_t), **_stats(alt_t)},
        "ours_colliding": sum(r["ours_colliding"] for r in rows),
        "ends_colliding_in_mujoco": sum(not r["valid_ends_mujoco"] for r in rows),
        "grasped_left_out": sum("left out" in p.description for p in probs),
        "rows": rows,
    }
    if ompl:
        out["ompl"] = {"solved": len(ompl_t), **_stats(ompl_t)}
        out["ompl_colliding"] = sum(r.get("ompl_colliding", False) for r in rows)
        out["ompl_solved_ours_not"] = sum(
            1 for r in rows if r.get("ompl_solved") and not r["ours_solved"]
        )
        # the speed-up over the problems both solved: each median over its own set would
        # compare easy problems of one with hard ones of the other
        both = [r for r in rows if r["ours_solved"] and r.get("ompl_solved")]
        out["both_solved"] = len(both)
        out["speedup"] = _speedup(both, "ours_ms")
        out["alternating_speedup"] = _speedup(
            [r for r in rows if r["alternating_solved"] and r.get("ompl_solved")],
            "alternating_ms",
        )
    return out


def _speedup(rows: list[dict[str, Any]], key: str) -> float | None:
    """OMPL's median over ours (`key`) on these rows, or None without rows."""
    if not rows:
        return None
    return float(np.median([r["ompl_ms"] for r in rows]) / np.median([r[key] for r in rows]))


def run(args: argparse.Namespace) -> int:
    """`robotrial bench planning --suite mbm`."""
    import platform

    from robotrial.benchmarks.planning import panda_path
    from robotrial.console import console, print_json, print_table, progress, write_result
    from robotrial.model import load_robot

    show = not args.json
    try:
        folder = fetch()
    except MbmError as exc:
        console.print(f"[red]MotionBenchMaker problems unavailable:[/red] {exc}")
        return 2
    scenes = args.scenes or SCENES
    unknown = [s for s in scenes if s not in SCENES]
    if unknown:
        console.print(f"[red]unknown scene(s) {unknown}[/red]; choose from {', '.join(SCENES)}")
        return 2
    panda = load_robot(panda_path())
    t0 = time.time()
    load0 = os.getloadavg()[0]
    results: dict[str, Any] = {}
    spheres = None
    with progress("MotionBenchMaker", len(scenes) * args.problems, enabled=show) as advance:
        for scene in scenes:
            probs = problems(folder, scene, args.problems, panda, spheres)
            spheres = probs[0].spheres
            results[scene] = run_scene(probs, args.time_limit, not args.no_ompl, advance)
    report = {
        "date": date.today().isoformat(),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, "
        f"{platform.python_implementation()} {platform.python_version()}",
        "seconds": time.time() - t0,
        "load_average": [load0, os.getloadavg()[0]],
        "problems_per_scene": args.problems,
        "time_limit_s": args.time_limit,
        "source": f"{VAMP_SDIST} source distribution on PyPI, {PROBLEMS_MEMBER} (Apache-2.0)",
        "scenes": results,
    }
    write_result(report, args.output)
    if args.md:
        args.md.parent.mkdir(parents=True, exist_ok=True)
        args.md.write_text(markdown(report))
    if getattr(args, "plot", None):
        plot_times(report, args.plot)
    if args.json:
        print_json(report)
    else:
        print_table("MotionBenchMaker, Panda (RRTConnect)", *_table(report))
    return 0


def plot_times(report: dict[str, Any], path: Path) -> Path:
    """A PNG of each scene's solve times (solved problems, log scale): ours and OMPL's
    side by side, boxes from the quartiles, whiskers to the 5th and 95th percentiles,
    every problem as a dot (the tails are what a median hides); VAMP's median range as
    measured here in grey, twice its p95 dashed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scenes = list(report["scenes"])
    fig, ax = plt.subplots(figsize=(9, 4.5))
    for k, (key, colour) in enumerate((("ours", "tab:blue"), ("ompl", "tab:orange"))):
        data, at = [], []
        for i, scene in enumerate(scenes):
            rows = report["scenes"][scene]["rows"]
            ms = [r[f"{key}_ms"] for r in rows if r.get(f"{key}_solved")]
            if ms:
                data.append(ms)
                at.append(i + (k - 0.5) * 0.35)
        if not data:
            continue
        ax.boxplot(
            data,
            positions=at,
            widths=0.3,
            whis=(5, 95),
            showfliers=False,
            patch_artist=True,
            boxprops={"facecolor": colour, "alpha": 0.35},
            medianprops={"color": colour},
        )
        rng = np.random.default_rng(0)
        for x, ms in zip(at, data, strict=True):
            ax.plot(x + rng.uniform(-0.1, 0.1, len(ms)), ms, ".", ms=2, color=colour)
        ax.plot([], [], "s", color=colour, label="ours" if key == "ours" else "OMPL + MuJoCo")
    for i, scene in enumerate(scenes):  # VAMP's median range and the p95 target
        if scene in VAMP_HERE_US:
            m0, m1, p0, _ = VAMP_HERE_US[scene]
            ax.fill_between([i - 0.4, i + 0.4], m0 / 1e3, m1 / 1e3, color="k", alpha=0.3, lw=0)
            ax.hlines(2 * p0 / 1e3, i - 0.4, i + 0.4, colors="k", linestyles="--", lw=1)
    ax.fill_between([], [], color="k", alpha=0.3, label="VAMP median (here, 4 runs)")
    ax.plot([], [], "k--", lw=1, label="2x VAMP p95 (its fastest run)")
    ax.set_yscale("log")
    ax.set_xticks(range(len(scenes)), scenes, rotation=20)
    ax.set_ylabel("solve time (ms)")
    ax.set_title(f"MotionBenchMaker, Panda, RRTConnect ({report['date']})")
    ax.legend()
    ax.grid(True, axis="y", which="both", alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _ms(v: float | None) -> str:
    return "-" if v is None else (f"{v:.3f}" if v < 10 else f"{v:.1f}")


def _table(report: dict[str, Any]) -> tuple[list[str], list[list[str]]]:
    cols = [
        "scene",
        "solved ours / OMPL",
        "median ms ours",
        "p95 ms ours",
        "median ms OMPL",
        "p95 ms OMPL",
        "speed-up (both solved)",
        "ours with OMPL's alternation: solved, median ms, speed-up",
        "colliding ours / OMPL",
    ]
    rows = []
    for scene, r in report["scenes"].items():
        o, alt = r.get("ompl", {}), r["alternating"]
        rows.append(
            [
                scene,
                f"{r['ours']['solved']} / {o.get('solved', '-')} of {r['problems']}",
                _ms(r["ours"]["median_ms"]),
                _ms(r["ours"]["p95_ms"]),
                _ms(o.get("median_ms")),
                _ms(o.get("p95_ms")),
                f"{r['speedup']:.0f}x" if r.get("speedup") else "-",
                f"{alt['solved']}, {_ms(alt['median_ms'])}, "
                + (f"{r['alternating_speedup']:.0f}x" if r.get("alternating_speedup") else "-"),
                f"{r['ours_colliding']} / {r.get('ompl_colliding', '-')}",
            ]
        )
    return cols, rows


def _vamp_table(report: dict[str, Any]) -> list[str]:
    """Ours beside VAMP as measured on this machine class (`VAMP_HERE_US`): the ratios
    run from VAMP's slowest run to its fastest. Ours timed as VAMP's script times its
    planner (a scene's queries back to back), in wall time and in the planning thread's
    CPU time, which leaves out the waits for a core; then cold, each query after MuJoCo's
    dense check and the other planners, in CPU time."""
    lines = [
        f"Beside {VAMP_SDIST} built from its source distribution and run with its own "
        "evaluate_mbm.py on a machine of this class (2-core AMD EPYC, AVX2; four runs, "
        "load about 2). Timer scope: VAMP's script times each planner call with a scene's "
        "queries back to back (one trial each, its environment built and its path "
        "simplified between them, no validation); its timer leaves out the buffers, the "
        "environment and the start and goal checks. Ours is timed the same way (a scene's "
        "queries back to back, each checker built before; MuJoCo's dense check, the "
        "alternating planner and OMPL run after) and includes the start and goal checks. "
        "Ours in wall time, then (CPU) in the planning thread's CPU time, which leaves out "
        "the waits for a core; cold (CPU): the same queries timed again, each right after "
        "MuJoCo's dense check of a path and the previous problem's planners, on a new "
        "checker. Microseconds:",
        "",
        "| scene | ours median | ours p95 | ours median (CPU) | ours p95 (CPU) "
        "| cold median / p95 (CPU) | VAMP median | VAMP p95 "
        "| ours / VAMP, median (CPU) | ours / VAMP, p95 (CPU) |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for scene, r in report["scenes"].items():
        med, p95 = r["ours"]["median_ms"], r["ours"]["p95_ms"]
        cpu = r.get("ours_cpu", {})
        cmed, cp95 = cpu.get("median_ms"), cpu.get("p95_ms")
        if scene not in VAMP_HERE_US or None in (med, p95, cmed, cp95):
            continue
        cold = r.get("ours_cold_cpu", {})
        cold_text = (
            f"{1e3 * cold['median_ms']:.0f} / {1e3 * cold['p95_ms']:.0f}"
            if cold.get("median_ms") is not None
            else "-"
        )
        m0, m1, p0, p1 = VAMP_HERE_US[scene]
        med, p95, cmed, cp95 = 1e3 * med, 1e3 * p95, 1e3 * cmed, 1e3 * cp95
        lines.append(
            f"| {scene} | {med:.0f} | {p95:.0f} | {cmed:.0f} | {cp95:.0f} | {cold_text} "
            f"| {m0}-{m1} | {p0}-{p1} "
            f"| {med / m1:.1f}-{med / m0:.1f}x ({cmed / m1:.1f}-{cmed / m0:.1f}x) "
            f"| {p95 / p1:.1f}-{p95 / p0:.1f}x ({cp95 / p1:.1f}-{cp95 / p0:.1f}x) |"
        )
    return [*lines, ""]


def markdown(report: dict[str, Any]) -> str:
    cols, rows = _table(report)
    lines = [
        "# MotionBenchMaker (Panda): `robotrial bench planning --suite mbm`",
        "",
        f"Measured {report['date']} on {report['machine']}"
        + (
            f" (load average {report['load_average'][0]:.1f} at the start, "
            f"{report['load_average'][1]:.1f} at the end)"
            if "load_average" in report
            else ""
        )
        + "; the first "
        f"{report['problems_per_scene']} problems of each scene, one run each, "
        f"{report['time_limit_s']:g} s limit. Data: {report['source']}, fetched at "
        "benchmark time into the user's cache. Ours: RRTConnect with balanced trees and "
        "dynamic domains on the sphere model (the fine cover asked where the first one "
        "touches an obstacle); beside it the same checks with OMPL's alternation of the "
        "trees (no balancing, no dynamic domains). "
        "OMPL: RRTConnect (OMPL 2 Python bindings) with MuJoCo as its validity checker, "
        "MoveIt's motion resolution. Ours is timed with a scene's queries back to back, "
        "as VAMP's evaluation script times its planner, then again cold (below). Every "
        "solved path, ours from both runs, is checked densely with MuJoCo.",
        "",
        "| " + " | ".join(cols) + " |",
        "| " + " | ".join("---" for _ in cols) + " |",
        *("| " + " | ".join(r) + " |" for r in rows),
        "",
        f"VAMP (published, README of {VAMP_SDIST}): RRTConnect over all seven scenes, "
        f"median {VAMP_MEDIAN_US:g} us on one core of a consumer desktop PC (SIMD, AVX2); "
        "no per-scene figures were found.",
        "",
        *_vamp_table(report),
    ]
    grasped = {s: r["grasped_left_out"] for s, r in report["scenes"].items()}
    if any(grasped.values()):
        lines.append(
            "Pick goals close the hand around an object; as MoveIt's allowed collisions "
            "let the fingers touch it there, that object is left out of the scene (for "
            "both planners) where the gripper's spheres reach it at the goal and no other "
            "link touches anything: "
            + ", ".join(f"{s} {n}" for s, n in grasped.items() if n)
            + " problems."
        )
        lines.append("")
    ends = {s: r["ends_colliding_in_mujoco"] for s, r in report["scenes"].items()}
    if any(ends.values()):
        lines.append(
            "Problems whose start or goal touches something in our MuJoCo model of the "
            "Panda (example-robot-data's meshes, not MBM's collision spheres): "
            + ", ".join(f"{s} {n}" for s, n in ends.items() if n)
            + "."
        )
        lines.append("")
    return "\n".join(lines)
