"""Navigation: costmap inflation, global planners, DWA, AMCL, the navigator, the bus node
and the paper's room B trial from the command line in the real simulator."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.sparse import lil_matrix
from scipy.sparse.csgraph import dijkstra as graph_dijkstra

from robotrial.nav.amcl import AMCL, AMCLConfig, compose
from robotrial.nav.costmap import INSCRIBED, LETHAL, Costmap, Footprint, Inflation
from robotrial.nav.dwa import DWAConfig, DWAPlanner, footprint_clearance
from robotrial.nav.navigator import Navigator, NavigatorConfig, Status
from robotrial.nav.planners import AStar, Dijkstra, NoPath, path_length

TINY = Footprint(0.1, 0.1)


def test_inflation_matches_hand_computed_cells():
    occ = np.zeros((11, 11), dtype=bool)
    occ[5, 5] = True
    cm = Costmap(occ, (0.0, 0.0), 0.1, Footprint(0.4, 0.2), Inflation(radius=0.3, cost_scaling=2.0))
    c = cm.cost
    assert c[5, 5] == LETHAL
    assert c[5, 6] == c[4, 5] == INSCRIBED  # 0.1 m: within the inscribed radius 0.1
    assert c[6, 6] == 231  # 0.1414 m: 252 exp(-2 * 0.0414) = 231.97
    assert c[5, 7] == 206  # 0.2 m: 252 exp(-0.2) = 206.3
    assert c[5, 8] == 168  # 0.3 m: 252 exp(-0.4) = 168.9
    assert c[5, 9] == 0  # 0.4 m: beyond the inflation radius
    assert c[0, 0] == 0


def _reference_length(free: np.ndarray, s: tuple[int, int], g: tuple[int, int]) -> float:
    rows, cols = free.shape
    graph = lil_matrix((rows * cols, rows * cols))
    for r in range(rows):
        for c in range(cols):
            if not free[r, c]:
                continue
            for dr in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    rr, cc = r + dr, c + dc
                    if (dr or dc) and 0 <= rr < rows and 0 <= cc < cols and free[rr, cc]:
                        graph[r * cols + c, rr * cols + cc] = np.hypot(dr, dc)
    d = graph_dijkstra(graph.tocsr(), indices=s[0] * cols + s[1])
    return float(d[g[0] * cols + g[1]])


@pytest.mark.parametrize("planner", [Dijkstra(), AStar()], ids=["dijkstra", "astar"])
def test_planners_find_optimal_paths_on_small_grids(planner):
    occ = np.zeros((10, 12), dtype=bool)
    cm = Costmap(occ, (0.0, 0.0), 1.0, TINY, Inflation(radius=0.0))
    path = planner.plan(cm, (0.5, 0.5), (9.5, 4.5))
    assert path_length(path) == pytest.approx(5 + 4 * np.sqrt(2))
    occ[0:9, 5] = True  # a wall with a gap at the top row
    rng = np.random.default_rng(3)
    occ[rng.random(occ.shape) < 0.1] = True
    occ[0, 0] = occ[0, 11] = occ[9, 5] = False
    cm = Costmap(occ, (0.0, 0.0), 1.0, TINY, Inflation(radius=0.0))
    path = planner.plan(cm, (0.5, 0.5), (11.5, 0.5))
    ref = _reference_length(~occ, (0, 0), (0, 11))
    assert np.isfinite(ref)
    assert path_length(path) == pytest.approx(ref)
    assert not cm.lethal[cm.world_to_cell(path)[:, 0], cm.world_to_cell(path)[:, 1]].any()


def test_planner_says_why_there_is_no_path():
    occ = np.zeros((10, 10), dtype=bool)
    occ[:, 5] = True
    cm = Costmap(occ, (0.0, 0.0), 1.0, TINY, Inflation(radius=0.0))
    with pytest.raises(NoPath, match="cannot be reached"):
        Dijkstra().plan(cm, (0.5, 0.5), (9.5, 0.5))
    with pytest.raises(NoPath, match="in or too close to an obstacle"):
        AStar().plan(cm, (0.5, 0.5), (5.5, 2.5))
    with pytest.raises(NoPath, match="outside the map"):
        AStar().plan(cm, (0.5, 0.5), (50.0, 2.5))


def test_dwa_drives_around_a_box_ahead():
    fp = Footprint(0.99, 0.67)
    occ = np.zeros((120, 200), dtype=bool)  # 10 x 6 m at 0.05 m
    occ[62:72, 60:72] = True  # a 0.6 x 0.5 m box 3 m ahead, 0.1 m beside the path
    cm = Costmap(occ, (0.0, 0.0), 0.05, fp, Inflation(1.0, 3.0))
    path = np.column_stack([np.linspace(0.5, 9.5, 181), np.full(181, 3.0)])
    dwa = DWAPlanner(fp, DWAConfig(max_speed=0.5, max_yaw_rate=1.0, period=0.1, sim_time=2.5))
    pose, vel = np.array([0.5, 3.0, 0.0]), (0.0, 0.0)
    for _ in range(300):
        res = dwa.compute(tuple(pose), vel, path, cm)
        assert res.ok
        vel = (res.v, res.w)
        pose = compose(pose, _arc(res.v, res.w, 0.1))
        assert footprint_clearance(cm, fp, pose[None]).min() > 0.0
        if pose[0] > 5.0:
            break
    assert pose[0] > 5.0, f"the robot did not get past the box: {pose}"
    assert abs(pose[1] - 3.0) < 0.3, "back near the path after the box"


def test_dwa_drives_at_full_top_speed_and_slows_for_a_doorway():
    fp = Footprint(0.99, 0.67)
    occ = np.zeros((100, 200), dtype=bool)  # 10 x 5 m at 0.05 m
    occ[:, 149:151] = True  # a thin wall at x = 7.5 m ...
    occ[40:60, 149:151] = False  # ... with a 1 m doorway, y 2 .. 3 m
    cm = Costmap(occ, (0.0, 0.0), 0.05, fp, Inflation(1.0, 3.0))
    path = Dijkstra().plan(cm, (0.5, 2.5), (9.5, 2.5))
    dwa = DWAPlanner(fp, DWAConfig(max_speed=1.0, max_yaw_rate=1.6, acc_lim_w=2.0, sim_time=2.2))
    assert dwa.path_speed((0.5, 2.5, 0.0), path, cm) == pytest.approx(1.0)
    pose, vel = np.array([0.5, 2.5, 0.0]), (0.0, 0.0)
    open_speeds, door_speeds = [], []
    for _ in range(600):
        res = dwa.compute(
            tuple(pose), vel, path, cm, goal_distance=float(np.hypot(9.5 - pose[0], 2.5 - pose[1]))
        )
        assert res.ok, f"stuck at {pose}"
        vel = (res.v, res.w)
        pose = compose(pose, _arc(res.v, res.w, 0.05))
        assert footprint_clearance(cm, fp, pose[None]).min() > 0.0
        if pose[0] < 4.0:
            open_speeds.append(res.v)
        if 7.0 < pose[0] < 8.0:
            door_speeds.append(res.v)
        if pose[0] > 8.5:
            break
    assert pose[0] > 8.5, f"the robot did not pass the doorway: {pose}"
    # in the open it reaches the top speed (1 m/s); for the doorway it slows down
    assert max(open_speeds) >= 0.98, f"top speed in the open: {max(open_speeds):.2f} m/s"
    assert max(door_speeds) < 0.6, f"in the doorway: {max(door_speeds):.2f} m/s"


def _arc(v: float, w: float, dt: float) -> np.ndarray:
    if abs(w) < 1e-9:
        return np.array([v * dt, 0.0, 0.0])
    return np.array([v / w * np.sin(w * dt), v / w * (1 - np.cos(w * dt)), w * dt])


def test_amcl_converges_from_a_wrong_guess_in_room_b():
    from robotrial.model import load_world
    from robotrial.model.gridmap import world_map
    from robotrial.sim import SimOptions, Simulation
    from robotrial.trials.nav import _beams

    nav_map = world_map(load_world("room_b"))
    sim = Simulation.create(
        "room_b", "mobile_manipulator", seed=2, options=SimOptions(cameras=False)
    )
    amcl = AMCL(nav_map.occupied, nav_map.origin, nav_map.resolution, AMCLConfig(), seed=2)
    amcl.initialize((1.5, 0.6, 0.3), std=(0.5, 0.5, 0.4))  # truth: (1, 1, 0)
    scan = next(r.data for r in sim.start() if r.kind == "scan")
    laser = (-0.3, 0.0, 0.0)
    sim.drive(0.3, 0.15)
    counts = []
    for _ in range(60):
        odo = sim.odometry.state
        amcl.update((odo.x, odo.y, odo.yaw), *_beams(scan), laser_pose=laser)
        counts.append(amcl.count)
        for r in sim.advance(0.1):
            if r.kind == "scan":
                scan = r.data
    sim.close()
    odo = sim.odometry.state
    est = compose(amcl.map_to_odom((odo.x, odo.y, odo.yaw)), (odo.x, odo.y, odo.yaw))
    x, y, yaw = sim.world.base_pose2d()
    assert np.hypot(est[0] - x, est[1] - y) < 0.15
    assert abs((est[2] - yaw + np.pi) % (2 * np.pi) - np.pi) < 0.08
    assert counts[-1] < counts[0], "KLD sampling should shrink the particle set as it converges"


def test_navigator_aborts_with_a_reason_when_the_goal_is_walled_off():
    occ = np.zeros((60, 60), dtype=bool)
    occ[:, 30] = True
    nav = Navigator(occ, (0.0, 0.0), 0.1, Footprint(0.5, 0.4), NavigatorConfig())
    nav.set_goal(5.0, 3.0, 0.0)
    t = 0.0
    while nav.status is Status.ACTIVE and t < 30:
        nav.step(t, (1.0, 3.0, 0.0), (0.0, 0.0))
        t += 0.05
    assert nav.status is Status.ABORTED
    assert "no path" in nav.message


def test_a_fine_slam_map_is_navigated_on_5_cm_costmaps_that_keep_thin_walls():
    """Hector's 2.5 cm map: the costmaps take 5 cm cells (as Nav2's default); a wall one
    fine cell thick still blocks, and a goal behind it is still refused."""
    occ = np.zeros((120, 120), dtype=bool)
    occ[:, 61] = True  # one 2.5 cm cell thick, at an odd column
    unknown = np.zeros_like(occ)
    unknown[:10, :10] = True
    nav = Navigator(occ, (0.0, 0.0), 0.025, Footprint(0.5, 0.4), NavigatorConfig(), unknown)
    cm = nav.global_costmap
    assert cm.resolution == 0.05 and cm.shape == (60, 60)
    assert cm.static[:, 30].all() and cm.static.sum() == 60
    assert cm.unknown[:5, :5].all() and cm.unknown.sum() == 25
    nav.set_goal(2.5, 1.5, 0.0)
    t = 0.0
    while nav.status is Status.ACTIVE and t < 30:
        nav.step(t, (0.5, 1.5, 0.0), (0.0, 0.0))
        t += 0.05
    assert nav.status is Status.ABORTED and "no path" in nav.message


@pytest.mark.parametrize(
    "config",
    [
        NavigatorConfig(planner="dijkstra"),
        NavigatorConfig(planner="hybrid", controller="pursuit"),
        NavigatorConfig(),
    ],
    ids=["dijkstra-dwa", "hybrid-pursuit", "hybrid-profile"],
)
def test_nav_node_plans_and_commands_on_the_bus(config):
    from robotrial.msgs.builtin_interfaces import Time
    from robotrial.msgs.geometry_msgs import (
        Point,
        Pose,
        PoseStamped,
        PoseWithCovariance,
        PoseWithCovarianceStamped,
        Quaternion,
    )
    from robotrial.msgs.nav_msgs import MapMetaData, OccupancyGrid, Odometry
    from robotrial.msgs.std_msgs import Header
    from robotrial.ros.bus import Bus
    from robotrial.ros.nav_node import GLOBAL_COSTMAP, NavNode

    bus = Bus()
    got: dict[str, list] = {}
    for topic in ("/cmd_vel", "/plan", GLOBAL_COSTMAP, "/move_base/status"):
        bus.subscribe(topic, lambda m, t=topic: got.setdefault(t, []).append(m))
    node = NavNode(bus, Footprint(0.5, 0.4), config=config)
    start = PoseWithCovarianceStamped(
        header=Header(frame_id="map"),
        pose=PoseWithCovariance(
            pose=Pose(Point(1.0, 3.0, 0), Quaternion()), covariance=[0.01] * 36
        ),
    )
    bus.publish("/initialpose", start, PoseWithCovarianceStamped)
    grid = np.zeros((60, 80), dtype=np.int8)
    grid[0, :] = grid[-1, :] = grid[:, 0] = grid[:, -1] = 100
    bus.publish(
        "/map",
        OccupancyGrid(
            header=Header(frame_id="map"),
            info=MapMetaData(
                resolution=0.1, width=80, height=60, origin=Pose(Point(0, 0, 0), Quaternion())
            ),
            data=grid.ravel().tolist(),
        ),
        OccupancyGrid,
    )
    goal = PoseStamped(header=Header(frame_id="map"), pose=Pose(Point(6.0, 3.0, 0), Quaternion()))
    bus.publish("/move_base_simple/goal", goal, PoseStamped)
    for i in range(5):
        odom = Odometry(header=Header(stamp=Time.from_sec(0.1 * i), frame_id="odom"))
        bus.publish("/odom", odom, Odometry)
    node.destroy()
    assert got[GLOBAL_COSTMAP][-1].info.width == 80
    plan = got["/plan"][-1]
    assert plan.poses[-1].pose.position.x == pytest.approx(6.0)
    assert any(m.linear.x > 0 or abs(m.angular.z) > 0 for m in got["/cmd_vel"])
    assert got["/move_base/status"][0].data.startswith("active")


def test_the_paper_trial_in_room_b_runs_from_the_command_line_on_a_map_server_map(tmp_path, capsys):
    """Room B's Table 1 route (the cylinder in the way) with the default stack, AMCL in
    MuJoCo, on the world written as a map_server map without metadata and started with
    --initial-pose (RViz's 2D Pose Estimate): reached, no contact, the plot drawn."""
    import json

    from robotrial.cli import main
    from robotrial.model import load_world
    from robotrial.model.gridmap import world_map
    from robotrial.model.mapfile import OccupancyMap, write_map

    m = world_map(load_world("room_b"))
    cells = np.where(m.occupied, 100, 0).astype(np.int8)
    write_map(tmp_path / "room_b", OccupancyMap(cells, m.resolution, (*m.origin, 0.0)))
    png = tmp_path / "paths.png"
    argv = ["nav", "--world", "room_b", "--map", str(tmp_path / "room_b.yaml"), "--speed", "1.0"]
    argv += ["--initial-pose", "1", "1", "0", "--json", "--plot", str(png)]
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    (run,) = out["runs"]
    assert out["summary"]["successes"] == 1 and out["map"].endswith("room_b.yaml")
    assert out["start_from"] == "initial pose" and out["planner"] == "hybrid"
    assert run["success"] and not run["collision"] and run["final_error"] <= 0.15, run
    assert 8.0 < run["distance"] < 12.0
    assert run["plan_ms_mean"] and run["local_ms_mean"]
    assert run["time"] > out["summary"]["shortest_time"]
    assert png.stat().st_size > 1000
    assert main(["nav", "--world", "nowhere"]) == 2
