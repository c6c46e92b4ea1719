"""`robotrial nav`: navigation trials to a goal, scored like the platform paper (layer 5).

    robotrial nav --world room_b --goal 6.8 6.6 0 --runs 10 --speed 0.3 [--map room_b.yaml]

Runs the mobile manipulator from the world's start to the goal `runs` times (seeds
seed..seed+runs-1) with AMCL, the global planner (`--planner`), the local controller
(`--controller`) and recoveries in the simulator;
prints success and time per run and the mean, min and max time of the successes (or
JSON with --json), and with --plot a PNG of the true paths over the map.

The goal is on the map: with `--map`, in the map's own frame. The robot's start on it
comes from `--initial-pose`, else from the map's metadata (a map `robotrial slam`
wrote says where its frame lies in the world), else AMCL localizes globally. A goal off
the map, in an obstacle or too near one is refused before anything drives (exit 2), as
is one the footprint planner cannot reach (exit 1).
"""

from __future__ import annotations

import argparse

from robotrial.console import add_json_flag, console, print_json, print_table, progress

HELP = "navigate to a goal with AMCL, a global planner and a local controller in the simulator"


# the navigator's global planners and local controllers (robotrial.nav.navigator)
PLANNERS = ("dijkstra", "astar", "hybrid", "auto")
CONTROLLERS = ("dwa", "pursuit", "profile")


def add_planner_argument(parser: argparse.ArgumentParser) -> None:
    """The --planner option (also `robotrial bench nav`'s); its default is the one
    navigation default, `robotrial.nav.DEFAULT_PLANNER`."""
    from robotrial.nav import DEFAULT_PLANNER

    parser.add_argument(
        "--planner",
        choices=PLANNERS,
        default=DEFAULT_PLANNER,
        help="global planner (hybrid: Hybrid-A* with the footprint; auto: A*, hybrid where "
        "needed; dijkstra: the platform paper's navfn) (default: %(default)s)",
    )


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--world", default="room_b", help="built-in world name or YAML file")
    parser.add_argument(
        "--goal",
        type=float,
        nargs=3,
        metavar=("X", "Y", "YAW"),
        help="goal pose on the map (m, m, rad; with --map in the map's frame); default: the "
        "world's `goal` spawn",
    )
    parser.add_argument(
        "--start", default="default", help="spawn pose name in the world (where the robot stands)"
    )
    parser.add_argument("--map", metavar="YAML", help="map_server map (default: ground truth)")
    parser.add_argument(
        "--initial-pose",
        type=float,
        nargs=3,
        metavar=("X", "Y", "YAW"),
        help="where the robot starts on the map (RViz's 2D Pose Estimate); default: from the "
        "map's metadata, else AMCL's global localization",
    )
    parser.add_argument("--runs", type=int, default=1, help="how many runs (seeds differ)")
    parser.add_argument("--speed", type=float, default=0.3, help="top speed (m/s)")
    add_planner_argument(parser)
    parser.add_argument(
        "--controller",
        choices=CONTROLLERS,
        default=None,
        help="local controller (profile: the fastest speed profile along a footprint plan, "
        "pursuit: regulated pure pursuit; default: profile with --planner hybrid, else dwa)",
    )
    parser.add_argument("--robot", default="mobile_manipulator", help="built-in robot or URDF")
    parser.add_argument("--seed", type=int, default=0, help="seed of the first run")
    parser.add_argument("--time-limit", type=float, help="simulated s before a run gives up")
    parser.add_argument("--plot", metavar="PNG", help="the paths on the map")
    add_json_flag(parser)


def run(args: argparse.Namespace) -> int:
    from robotrial.model import ModelError, load_world
    from robotrial.model.gridmap import file_map, world_map
    from robotrial.nav import default_controller
    from robotrial.trials.nav import (
        NavTrialSetup,
        footprint_of_robot,
        map_start,
        plot_paths,
        refuse_goal,
        run_trials,
        shortest_time,
        start_pose,
        summarize,
    )

    try:
        world = load_world(args.world)
        goal = tuple(args.goal) if args.goal else _spawn_goal(world)
        setup = NavTrialSetup(
            world=args.world,
            goal=goal,
            start=args.start,
            robot=args.robot,
            map_path=args.map,
            speed=args.speed,
            planner=args.planner,
            controller=args.controller or default_controller(args.planner),
            time_limit=args.time_limit,
            initial_pose=tuple(args.initial_pose) if args.initial_pose else None,
        )
        nav_map = file_map(args.map) if args.map else world_map(world)
        start = map_start(nav_map, world, start_pose(world, args.start), setup.initial_pose)
        footprint = footprint_of_robot(args.robot)
        check = refuse_goal(setup, nav_map, start, footprint)
    except (ValueError, KeyError, OSError, ModelError) as err:
        console.print(f"[red]robotrial nav: {_words(err)}[/red]", highlight=False, soft_wrap=True)
        return 2
    if not check.ok:
        code = {"here": 0, "unreachable": 1}.get(check.kind, 2)
        where = " (with --map, goals are in the map's frame)" if args.map else ""
        hint = where if check.kind in ("off_map", "in_obstacle") else ""
        console.print(f"robotrial nav: {check.reason}{hint}", highlight=False, soft_wrap=True)
        return code
    length, best = (None, None)
    if start.pose is not None:
        length, best = shortest_time(setup, nav_map, footprint, start.pose)
    results = []
    with progress(f"nav {world.name}", total=args.runs, enabled=not args.json) as advance:

        def on_run(r) -> None:
            results.append(r)
            advance()

        try:
            run_trials(setup, args.runs, args.seed, on_run=on_run)
        except ValueError as err:
            console.print(
                f"[red]robotrial nav: {_words(err)}[/red]", highlight=False, soft_wrap=True
            )
            return 2
    summary = summarize(results, best)
    summary["shortest_length"] = length
    plot = None
    if args.plot:
        title = f"{world.name}: {summary['successes']}/{len(results)} at {args.speed} m/s"
        origin = start.pose or goal
        plot = str(plot_paths(args.plot, nav_map, results, origin, goal, title=title))
    if args.json:
        print_json(
            {
                "world": world.name,
                "goal": goal,
                "speed": args.speed,
                "map": nav_map.source,
                "start": start.pose,
                "start_from": start.how,
                "planner": args.planner,
                "controller": setup.controller,
                "runs": [r.summary() for r in results],
                "summary": summary,
                "plot": plot,
            }
        )
        return 0 if summary["successes"] == len(results) else 1
    print_table(
        f"robotrial nav {world.name} -> {goal} at {args.speed} m/s ({nav_map.source} map)",
        ["seed", "success", "time (s)", "status", "message"],
        [(r.seed, "yes" if r.success else "no", r.time, r.status, r.message) for r in results],
    )
    fmt = lambda v: "-" if v is None else f"{v:.2f}"  # noqa: E731
    print_table(
        "summary",
        [
            "successes",
            "mean (s)",
            "min (s)",
            "max (s)",
            "shortest (s)",
            "mean / shortest",
            "collisions",
        ],
        [
            (
                f"{summary['successes']}/{summary['runs']}",
                fmt(summary["mean_time"]),
                fmt(summary["min_time"]),
                fmt(summary["max_time"]),
                fmt(best),
                fmt(summary.get("ratio")),
                summary["collisions"],
            )
        ],
    )
    console.print(f"paths: {plot}" if plot else "paths: add --plot PNG to draw them on the map")
    return 0 if summary["successes"] == len(results) else 1


def _words(err: BaseException) -> str:
    """An error as one line (a KeyError's message comes quoted)."""
    text = str(err.args[0]) if isinstance(err, KeyError) and err.args else str(err)
    return " ".join(text.split())


def _spawn_goal(world) -> tuple[float, float, float]:
    if "goal" not in world.spawns:
        raise ValueError(f"world {world.name!r} has no `goal` spawn; give --goal X Y YAW")
    p = world.spawn("goal")
    return float(p.xyz[0]), float(p.xyz[1]), float(p.yaw)
