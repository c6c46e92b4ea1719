"""`robotrial plan`: plan an arm motion (the PlanTask service) from the command line.

Layer 5: parses arguments into a robotrial_msgs/PlanTask request (or reads one as the
JSON rosbridge would carry), calls the planning task, prints the answer and writes plots
of the joint curves and of the end-effector path.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from robotrial.cli.robot_source import add_robot_source_arguments, load_robot_from_args
from robotrial.console import add_json_flag, console, print_json, print_table

HELP = "plan an arm motion around obstacles to an end-effector goal (the PlanTask service)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_robot_source_arguments(parser, default="desk_arm", tool=True)
    parser.add_argument("--world", default="", help="built-in world name or YAML file (optional)")
    parser.add_argument(
        "--goal", nargs=3, type=float, metavar=("X", "Y", "Z"), help="end-effector position (m)"
    )
    parser.add_argument(
        "--goal-rpy",
        nargs=3,
        type=float,
        metavar=("R", "P", "Y"),
        help="end-effector orientation (rad); default: position only",
    )
    parser.add_argument(
        "--start",
        nargs="+",
        type=float,
        metavar="Q",
        help="current values of the planning joints (default: zero, clipped to the limits)",
    )
    parser.add_argument(
        "--obstacle",
        nargs="+",
        type=float,
        action="append",
        default=[],
        metavar="V",
        help="a box: SX SY SZ X Y Z [ROLL PITCH YAW] (m, rad); repeat for more",
    )
    parser.add_argument(
        "--object",
        nargs="+",
        type=float,
        metavar="V",
        help="the carried box: SX SY SZ X Y Z [ROLL PITCH YAW]",
    )
    parser.add_argument(
        "--planner",
        default="",
        help="rrt_connect (default), rrt, rrt_star, prm, prm_star, sbl, est, biest",
    )
    parser.add_argument("--time-limit", type=float, default=0.0, help="s (0 = default)")
    parser.add_argument(
        "--request",
        type=Path,
        help="a PlanTask request as rosbridge JSON (replaces the options above)",
    )
    parser.add_argument("--seed", type=int, default=None, help="random seed, for a repeatable plan")
    parser.add_argument(
        "--plot", type=Path, metavar="PNG", help="joint curves and hand path of the plan"
    )
    add_json_flag(parser)


def _box(values: list[float], what: str, name: str):
    from robotrial.geometry import Pose
    from robotrial.msgs.geometry_msgs import Pose as PoseMsg
    from robotrial.msgs.geometry_msgs import Vector3
    from robotrial.msgs.robotrial_msgs import Box

    if len(values) not in (6, 9):
        raise SystemExit(
            f"robotrial plan: {what} takes SX SY SZ X Y Z [ROLL PITCH YAW], "
            f"got {len(values)} numbers"
        )
    rpy = values[6:9] if len(values) == 9 else (0.0, 0.0, 0.0)
    pose = Pose.from_xyz_rpy(values[3:6], rpy)
    return Box(id=name, size=Vector3(*values[:3]), pose=PoseMsg.from_pose(pose))


def build_request(args: argparse.Namespace, joint_names: list[str]):
    """The PlanTask request from the options (or the --request file)."""
    from robotrial.geometry import Pose
    from robotrial.msgs.geometry_msgs import Point, Quaternion
    from robotrial.msgs.geometry_msgs import Pose as PoseMsg
    from robotrial.msgs.robotrial_msgs import PlanTaskRequest
    from robotrial.msgs.sensor_msgs import JointState

    if args.request:
        try:
            data = json.loads(args.request.read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise SystemExit(f"robotrial plan: cannot read {args.request}: {exc}") from None
        return PlanTaskRequest.from_dict(data.get("args", data))
    if args.goal is None:
        raise SystemExit("robotrial plan: give --goal X Y Z (or --request FILE)")
    if args.goal_rpy is not None:
        goal = PoseMsg.from_pose(Pose.from_xyz_rpy(args.goal, args.goal_rpy))
    else:
        goal = PoseMsg(Point(*args.goal), Quaternion(0.0, 0.0, 0.0, 0.0))
    return PlanTaskRequest(
        current_joints=JointState(name=joint_names, position=list(args.start or [])),
        obstacles=[
            _box(v, f"--obstacle #{i + 1}", f"obstacle{i + 1}") for i, v in enumerate(args.obstacle)
        ],
        object=_box(args.object, "--object", "object") if args.object else _empty_box(),
        ee_goal=goal,
        planner=args.planner,
        time_limit=args.time_limit,
    )


def _empty_box():
    from robotrial.msgs.robotrial_msgs import Box

    return Box()


def run(args: argparse.Namespace) -> int:
    from robotrial.model import ModelError, load_world
    from robotrial.planning.task import TaskPlanner
    from robotrial.ros.plan_task import answer

    try:
        robot = load_robot_from_args(args)
        world = load_world(args.world) if args.world else None
    except (ModelError, KeyError, FileNotFoundError) as exc:
        raise SystemExit(f"robotrial plan: {exc}") from None
    planner = TaskPlanner(robot, world)
    request = build_request(args, planner.joint_names)
    if not request.current_joints.position:
        home = np.clip(np.zeros(planner.kin.d), planner.kin.lower, planner.kin.upper)
        request.current_joints.name = planner.joint_names
        request.current_joints.position = [float(v) for v in home]
    resp, result = answer(planner, request, seed=args.seed)
    plots: list[str] = []
    if resp.success and args.plot is not None:
        plots = [write_plot(result, planner, request, args.plot)]
    stats = {k: v for k, v in result.stats.items() if isinstance(v, int | float | str)}
    if args.json:
        out = resp.to_dict()
        out["failure"] = result.failure
        out["stats"] = stats
        out["plots"] = plots
        print_json(out)
    else:
        style = "green" if resp.success else "red"
        console.print(f"[{style}]{'planned' if resp.success else 'failed'}[/]: {resp.message}")
        if resp.success:
            print_table(
                "goal joints (rad)",
                planner.joint_names,
                [[float(v) for v in resp.goal_joints]],
            )
            print_table("statistics", ["what", "value"], sorted(stats.items()))
            for p in plots:
                console.print(f"wrote {p}")
    return 0 if resp.success else 1


def write_plot(result, planner, request, png: Path) -> str:
    """Joint positions over time (as the platform paper's Figs. 10 to 12) beside the
    end-effector path with the obstacles (as its Fig. 13), in one PNG. Returns its path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    traj = result.trajectory
    png.parent.mkdir(parents=True, exist_ok=True)
    fig = plt.figure(figsize=(14, 5.5))
    ax = fig.add_subplot(1, 2, 1)
    for j, name in enumerate(planner.joint_names):
        ax.plot(traj.t, traj.q[:, j], label=name)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("joint position (rad)")
    ax.set_title(f"{planner.robot.name}: joint positions ({result.stats.get('planner', '')})")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)

    ee = planner.kin.fk(traj.q)[:, planner.kin.tip, :3, 3]
    ax3 = fig.add_subplot(1, 2, 2, projection="3d")
    ax3.plot(ee[:, 0], ee[:, 1], ee[:, 2], color="tab:blue", label="end effector")
    ax3.scatter(*ee[0], color="tab:green", label="start")
    ax3.scatter(*ee[-1], color="tab:red", label="goal")
    for box in request.obstacles:
        _draw_box(ax3, box)
    ax3.set_xlabel("x (m)")
    ax3.set_ylabel("y (m)")
    ax3.set_zlabel("z (m)")
    lo, hi = ee.min(axis=0), ee.max(axis=0)
    mid, half = (lo + hi) / 2, max(float(np.max(hi - lo)) / 2, 0.05)
    ax3.set_xlim(mid[0] - half, mid[0] + half)
    ax3.set_ylim(mid[1] - half, mid[1] + half)
    ax3.set_zlim(mid[2] - half, mid[2] + half)
    ax3.legend(loc="upper left", fontsize=8)
    ax3.set_title("end-effector path")
    fig.tight_layout()
    fig.savefig(png, dpi=120)
    plt.close(fig)
    return str(png)


def _draw_box(ax, box) -> None:
    from itertools import product

    size = np.array([box.size.x, box.size.y, box.size.z])
    m = box.pose.to_pose().matrix()
    corners = np.array(list(product(*[(-s / 2, s / 2) for s in size])))
    world = corners @ m[:3, :3].T + m[:3, 3]
    for i, j in (
        (0, 1),
        (0, 2),
        (0, 4),
        (1, 3),
        (1, 5),
        (2, 3),
        (2, 6),
        (3, 7),
        (4, 5),
        (4, 6),
        (5, 7),
        (6, 7),
    ):
        ax.plot(*zip(world[i], world[j], strict=True), color="grey", linewidth=1)
