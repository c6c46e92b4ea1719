"""The g2rViewer desk experiment on the server: plan, run under physics, compare (layer 5).

The desk arm's hand goes from near (0.15, -0.15, 0.02) to near (0.18, 0.2, 0.02) m in its
base frame, around obstacle C (0.1 x 0.1 x 0.2 m at (0.2, 0, 0.15)) or with the desk
clear, as in the paper's Figs. 12 and 13. The request goes through the same PlanTask
machinery the page uses; the timed trajectory runs in MuJoCo under the arm's joint
controller, and the hand's path there is compared with the path the plan's joint values
give (the largest distance between them at equal times).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robotrial.trials.kinds import Outcome

SETTLE = 0.5  # s of simulation after the trajectory ends


def desk_run(obstacle: bool, planner: str, seed: int, out: Path) -> Outcome:
    """One run; its figures and a plot of the planned and the simulated hand paths."""
    from robotrial.geometry import Pose
    from robotrial.kinematics.chain import Kinematics
    from robotrial.model import load_robot, load_world
    from robotrial.planning.problems import DESK_OBSTACLE, desk_task
    from robotrial.planning.task import TaskPlanner, TaskRequest
    from robotrial.sim import SimOptions, Simulation
    from robotrial.sim.controllers import JointReference

    robot, world = load_robot("desk_arm"), load_world("desk")
    problem = desk_task(robot, world)
    planner_ = TaskPlanner(robot, world)
    kin = Kinematics(robot, planner_.joint_names)
    goal = Pose.from_matrix(kin.link_pose(problem.goal))
    _, shape, pose = DESK_OBSTACLE
    request = TaskRequest(
        positions=np.asarray(problem.start),
        joint_names=planner_.joint_names,
        goal_position=np.asarray(goal.xyz),
        goal_orientation=np.asarray(goal.quat),
        obstacles=[DESK_OBSTACLE] if obstacle else [],
        planner=planner,
        time_limit=5.0,
    )
    result = planner_.plan(request, seed=seed)
    figures: dict = {
        "obstacle": obstacle,
        "planning_time": result.planning_time,
        "message": result.message,
    }
    if not result.success or result.trajectory is None:
        return Outcome(False, figures, {})
    traj = result.trajectory
    sim = Simulation.create(world, robot, seed=seed, options=SimOptions(cameras=False))
    try:
        data = sim.world.data
        joints = sim.joints
        assert joints is not None
        index = [joints.names.index(n) for n in planner_.joint_names]
        data.qpos[joints.qadr[index]] = problem.start
        sim.world.forward()
        joints.hold(data)
        sim.follow(JointReference(planner_.joint_names, traj.t, traj.q, traj.qd))
        base_inv = np.linalg.inv(sim.frame_pose(robot.root))
        hand = robot.end_effector
        steps = round((traj.duration + SETTLE) / sim.control_dt)
        times, simulated = [], []
        for _ in range(steps):
            sim.control_step()
            times.append(sim.world.time)
            simulated.append((base_inv @ sim.frame_pose(hand))[:3, 3])
    finally:
        sim.close()
    times_a, sim_path = np.asarray(times), np.asarray(simulated)
    q_at = np.stack(
        [np.interp(np.minimum(times_a, traj.duration), traj.t, traj.q[:, j]) for j in range(kin.d)],
        axis=1,
    )
    plan_path = kin.link_pose(q_at, hand)[:, :3, 3]
    deviation = np.linalg.norm(sim_path - plan_path, axis=1)
    final = float(np.linalg.norm(sim_path[-1] - goal.xyz))
    figures.update(
        {
            "duration": traj.duration,
            "path_length": float(result.stats.get("path_length", 0.0)),
            "ee_deviation": float(deviation.max()),
            "ee_deviation_rms": float(np.sqrt(np.mean(deviation**2))),
            "ee_final_error": final,
        }
    )
    out.mkdir(parents=True, exist_ok=True)
    png = out / f"desk_{'C' if obstacle else 'clear'}_{seed}.png"
    plot_hand_paths(png, plan_path, sim_path, pose if obstacle else None, shape.size)
    return Outcome(final < 0.01, figures, {"hand_paths": str(png)})


def plot_hand_paths(png: Path, plan: np.ndarray, simulated: np.ndarray, obstacle, size) -> None:
    """Top and side views of the planned and the simulated hand paths (cm), obstacle C."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    fig, axes = plt.subplots(1, 2, figsize=(9, 4))
    for ax, (i, j), label in zip(
        axes, [(0, 1), (0, 2)], ["top (x, y)", "side (x, z)"], strict=True
    ):
        ax.plot(100 * plan[:, i], 100 * plan[:, j], "b-", label="plan")
        ax.plot(100 * simulated[:, i], 100 * simulated[:, j], "r--", label="MuJoCo")
        if obstacle is not None:
            c, h = obstacle.xyz, np.asarray(size) / 2
            ax.add_patch(
                Rectangle(
                    (100 * (c[i] - h[i]), 100 * (c[j] - h[j])),
                    200 * h[i],
                    200 * h[j],
                    color="0.6",
                    alpha=0.5,
                    label="obstacle C",
                )
            )
        ax.set_title(label)
        ax.set_xlabel(f"{'xyz'[i]} (cm)")
        ax.set_ylabel(f"{'xyz'[j]} (cm)")
        ax.set_aspect("equal")
    axes[1].legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(png, dpi=100)
    plt.close(fig)
