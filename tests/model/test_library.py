"""The built-in robots and worlds: they load, have the sizes the trials rely on, and the
ground-truth occupancy grid draws them where they are."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from robotrial.geometry import Box, Cylinder, Pose, Sphere
from robotrial.kinematics.reference import link_poses
from robotrial.model import ModelError, load_robot, load_world
from robotrial.model.gridmap import world_occupancy
from robotrial.model.library import robot_names, robot_path, world_names
from robotrial.model.urdf import load_urdf
from robotrial.model.world import Obstacle, World

ROBOTS = ["desk_arm", "husky", "manipulator_h", "mobile_manipulator"]
WORLDS = ["apartment", "desk", "room_a", "room_b", "room_c"]
ROOMS = ["room_a", "room_b", "room_c"]
HUSKY_HALF_WIDTH = 0.335


def test_the_library_lists_every_builtin() -> None:
    assert set(ROBOTS) <= set(robot_names())
    assert set(WORLDS) <= set(world_names())


@pytest.mark.parametrize("name", ROBOTS)
def test_builtin_robot_is_physically_sound(name: str) -> None:
    model = load_robot(name)
    assert model.repairs == (), f"{name} needed repairs: {model.repairs}"
    assert model.tcp and model.end_effector == model.tcp
    for link in model.links:
        for c in link.collisions:
            assert isinstance(c.geometry, Box | Cylinder | Sphere), link.name
        for v in link.visuals:
            assert v.material in model.materials, f"{link.name} visual has no material"
        if link.inertial is None:
            assert not link.visuals, f"{link.name} has a body but no mass"
            continue
        assert link.inertial.mass > 0
        eig = np.sort(np.linalg.eigvalsh(link.inertial.tensor()))
        assert eig[0] > 0, link.name
        assert eig[0] + eig[1] >= eig[2] * (1 - 1e-9), f"{link.name} breaks the triangle inequality"
    for joint in model.actuated_joints:
        assert joint.limit is not None and joint.limit.effort > 0 and joint.limit.velocity > 0
        if joint.type != "continuous":
            assert joint.limit.lower < joint.limit.upper
    for group, joints in model.metadata["groups"].items():
        assert set(joints) <= {j.name for j in model.joints}, group


@pytest.mark.parametrize("name", WORLDS)
def test_builtin_world_loads_with_a_default_spawn(name: str) -> None:
    world = load_world(name)
    assert world.name == name
    assert "default" in world.spawns
    assert world.lights


# --- desk_arm --------------------------------------------------------------------------


def _jacobian(model, poses, tcp: str) -> np.ndarray:
    """Geometric 6 x n Jacobian of the tcp over the actuated joints (all revolute here)."""
    p_tcp = poses[tcp][:3, 3]
    cols = []
    for j in model.actuated_joints:
        frame = poses[j.child]
        axis = frame[:3, :3] @ np.asarray(j.axis)
        cols.append(np.r_[np.cross(axis, p_tcp - frame[:3, 3]), axis])
    return np.array(cols).T


def _solve_ik(model, target: np.ndarray, down: bool, q0: np.ndarray) -> tuple[np.ndarray, float]:
    """Damped least squares on the reference FK: tcp at `target`, with `down` its +z
    (approach) axis pointing at the table."""
    lo, hi = model.joint_limits()
    arm = [model.joint_names.index(n) for n in model.metadata["groups"]["arm"]]
    q = q0.copy()
    err = np.inf
    for _ in range(200):
        poses = link_poses(model, q)
        tcp = poses[model.tcp]
        e = np.r_[target - tcp[:3, 3], np.cross(tcp[:3, 2], [0, 0, -1]) if down else np.zeros(3)]
        err = float(np.linalg.norm(e))
        if err < 1e-6:
            break
        jac = _jacobian(model, poses, model.tcp)[:, arm]
        if not down:
            jac, e = jac[:3], e[:3]
        step = jac.T @ np.linalg.solve(jac @ jac.T + 1e-4 * np.eye(len(e)), e)
        step *= min(1.0, 0.2 / np.abs(step).max())
        q[arm] = np.clip(q[arm] + step, lo[arm], hi[arm])
    return q, err


@pytest.mark.parametrize("target", [(0.15, -0.15, 0.02), (0.18, 0.2, 0.02)], ids=["start", "goal"])
def test_desk_arm_reaches_the_experiment_points_from_above(target) -> None:
    model = load_robot("desk_arm")
    q0 = np.zeros(len(model.joint_names))
    q0[:3] = (np.arctan2(target[1], target[0]), 0.5, 1.5)
    q, err = _solve_ik(model, np.array(target), down=True, q0=q0)
    assert err < 1e-4
    poses = link_poses(model, q)
    # nothing of the arm dips into the table on the way down to the point
    assert min(p[2, 3] for name, p in poses.items() if name != "base_link") > 0.0


def test_desk_arm_lifts_the_gripper_over_the_obstacle_box() -> None:
    model = load_robot("desk_arm")
    q0 = np.zeros(len(model.joint_names))
    q0[1:3] = (0.3, 0.8)
    q, err = _solve_ik(model, np.array([0.2, 0.0, 0.31]), down=False, q0=q0)
    assert err < 1e-4
    poses = link_poses(model, q)
    box_lo, box_hi = np.array([0.15, -0.05, 0.05]), np.array([0.25, 0.05, 0.25])
    for name, p in poses.items():
        inside = np.all((p[:3, 3] > box_lo) & (p[:3, 3] < box_hi))
        assert not inside, f"{name} is inside the obstacle"


def test_desk_arm_gripper_fingers_mirror_each_other() -> None:
    model = load_robot("desk_arm")
    gripper = model.metadata["gripper"]
    q = np.zeros(len(model.joint_names))
    q[model.joint_names.index(gripper["joints"][0])] = gripper["open"]
    poses = link_poses(model, q)
    left = poses["finger_left_link"][:3, 3]
    right = poses["finger_right_link"][:3, 3]
    tcp = poses["tcp"][:3, 3]
    assert np.linalg.norm(left - right) == pytest.approx(2 * gripper["open"])
    assert np.linalg.norm((left + right) / 2 - tcp[:3]) < 0.06


# --- manipulator_h, husky, mobile_manipulator ------------------------------------------


def test_manipulator_h_reach_and_mass() -> None:
    model = load_robot("manipulator_h")
    lo, hi = model.joint_limits()
    rng = np.random.default_rng(0)
    samples = np.vstack([np.zeros(len(lo)), rng.uniform(lo, hi, size=(300, len(lo)))])
    reach = 0.0
    for q in samples:
        poses = link_poses(model, q)
        reach = max(reach, float(np.linalg.norm(poses["tcp"][:3, 3] - poses["link2"][:3, 3])))
    assert reach == pytest.approx(0.654, abs=0.02)
    assert model.total_mass == pytest.approx(5.0, rel=0.1)


def _collision_extent(model, frame: str) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned bounds of every collision shape at q = 0, in `frame`."""
    poses = link_poses(model, np.zeros(len(model.joint_names)))
    to_frame = np.linalg.inv(poses[frame])
    points = []
    for link in model.links:
        for c in link.collisions:
            m = to_frame @ poses[link.name] @ c.origin.matrix()
            g = c.geometry
            if isinstance(g, Box):
                half = np.asarray(g.size) / 2
            elif isinstance(g, Cylinder):
                half = np.array([g.radius, g.radius, g.length / 2])
            else:
                half = np.full(3, g.radius)
            corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
            points.append((corners * half) @ m[:3, :3].T + m[:3, 3])
    pts = np.vstack(points)
    return pts.min(axis=0), pts.max(axis=0)


def test_husky_footprint_mass_and_drive() -> None:
    model = load_robot("husky")
    lo, hi = _collision_extent(model, "base_footprint")
    assert hi[0] - lo[0] == pytest.approx(0.99, abs=0.01)
    assert hi[1] - lo[1] == pytest.approx(0.67, abs=0.01)
    assert lo[2] == pytest.approx(0.0, abs=1e-6), "the wheels stand on the floor"
    assert model.total_mass == pytest.approx(50.0, rel=0.1)
    drive = model.metadata["drive"]
    assert drive["type"] == "skid_steer" and drive["max_speed"] == 1.0
    assert {"max_accel", "max_yaw_rate", "wheel_separation", "wheel_radius"} <= set(drive)
    wheels = [j for j in model.joints if j.type == "continuous"]
    assert len(wheels) == 4
    assert link_poses(model, np.zeros(4))["base_link"][2, 3] == pytest.approx(drive["wheel_radius"])


def test_mobile_manipulator_sensors_and_groups() -> None:
    model = load_robot("mobile_manipulator")
    groups = model.metadata["groups"]
    assert len(groups["arm"]) == 6 and len(groups["base"]) == 4
    assert model.tcp == "arm_tcp"
    lidar = model.sensor("velodyne")
    assert lidar.type == "lidar" and lidar.rate_hz == 10
    p = lidar.params
    assert p["rings"] == 16
    assert np.rad2deg([p["vertical_min"], p["vertical_max"]]) == pytest.approx([-15, 15])
    assert np.rad2deg(p["horizontal_resolution"]) == pytest.approx(0.2)
    assert (p["range_min"], p["range_max"], p["noise"]) == (0.1, 100.0, 0.01)
    kinds = sorted(s.type for s in model.sensors)
    assert kinds == ["camera", "camera", "camera", "depth_camera", "depth_camera", "imu", "lidar"]
    poses = link_poses(model, np.zeros(len(model.joint_names)))
    lidar_z = poses["velodyne_link"][2, 3]
    assert 0.5 < lidar_z < 1.0, "the lidar's level ring must hit the 1.2 m room walls"
    # the arm stands ahead of the mast and the mast above the arm's shoulder housing
    assert poses["arm_base_link"][0, 3] - poses["velodyne_link"][0, 3] >= 0.4


def test_mobile_manipulator_lidar_resolution_is_a_xacro_argument() -> None:
    path = robot_path("mobile_manipulator")
    fine = load_urdf(path, xacro_args={"lidar_resolution_deg": "0.1"})
    assert np.rad2deg(fine.sensor("velodyne").params["horizontal_resolution"]) == pytest.approx(0.1)
    with pytest.raises(ModelError, match="lidar_resolution_deg"):
        load_urdf(path, xacro_args={"lidar_resolution_deg": "0.5"})


# --- worlds ----------------------------------------------------------------------------


@pytest.mark.parametrize("name", ROOMS)
def test_room_interior_spawn_and_goal(name: str) -> None:
    world = load_world(name)
    (x0, y0), (x1, y1) = world.interior
    assert (x0, y0) == (0.0, 0.0)
    assert (x1 - x0, y1 - y0) == pytest.approx((7.78, 7.62))
    start, goal = world.spawn("default"), world.spawn("goal")
    assert start.xyz[:2] == pytest.approx((1.0, 1.0), abs=0.3)
    assert start.yaw == pytest.approx(0.0)
    assert goal.xyz[0] > 6 and goal.xyz[1] > 6


def _passable(world: World, clearance: float, resolution: float = 0.05):
    """Cells whose centre is farther than `clearance` from anything, labelled by region."""
    grid = world_occupancy(world, resolution=resolution)
    distance = ndimage.distance_transform_edt(~grid.occupied) * resolution
    labels, _ = ndimage.label(distance > clearance)
    return grid, labels


@pytest.mark.parametrize("name", ROOMS)
def test_room_leaves_a_husky_a_0_8_m_way_from_spawn_to_goal(name: str) -> None:
    world = load_world(name)
    grid, labels = _passable(world, clearance=0.4)
    start = labels[grid.cell_of(*world.spawn("default").xyz[:2])]
    goal = labels[grid.cell_of(*world.spawn("goal").xyz[:2])]
    assert start != 0 and start == goal


def test_apartment_every_spawn_is_reachable_through_the_doorways() -> None:
    world = load_world("apartment")
    grid, labels = _passable(world, clearance=HUSKY_HALF_WIDTH)
    regions = {name: labels[grid.cell_of(*pose.xyz[:2])] for name, pose in world.spawns.items()}
    assert 0 not in regions.values(), regions
    assert len(set(regions.values())) == 1, regions
    assert len(world.spawns) >= 4 and all(o.mass > 0 for o in world.objects) and world.objects


def test_desk_table_top_is_the_plane_z_0() -> None:
    world = load_world("desk")
    top = next(o for o in world.obstacles if o.name == "table_top")
    assert top.pose.xyz[2] + top.geometry.size[2] / 2 == pytest.approx(0.0)
    lo = np.array(top.pose.xyz[:2]) - np.array(top.geometry.size[:2]) / 2
    hi = np.array(top.pose.xyz[:2]) + np.array(top.geometry.size[:2]) / 2
    for point in [(0, 0), (0.15, -0.15), (0.18, 0.2), (0.2, 0)]:
        assert np.all((lo < point) & (point < hi))
    assert world.floor.height == pytest.approx(-0.75, abs=0.05)
    assert world.spawn().xyz == (0.0, 0.0, 0.0)


# --- ground-truth occupancy grid -------------------------------------------------------


def test_room_a_grid_is_its_walls_and_a_free_interior() -> None:
    world = load_world("room_a")
    grid = world_occupancy(world, resolution=0.05)
    x, y = grid.cell_centers()
    h = grid.resolution / 2
    inside = (x - h >= 0) & (x + h <= 7.78) & (y - h >= 0) & (y + h <= 7.62)
    assert not grid.occupied[inside].any()
    in_walls = (
        (x > -0.15)
        & (x < 7.93)
        & (y > -0.15)
        & (y < 7.77)
        & ~((x > 0) & (x < 7.78) & (y > 0) & (y < 7.62))
    )
    assert grid.occupied[in_walls].all()
    far = (x < -0.2) | (x > 7.98) | (y < -0.2) | (y > 7.82)
    assert not grid.occupied[far].any()
    # a closed ring: the free cells inside are one region, not connected to the outside
    labels, _ = ndimage.label(~grid.occupied)
    assert labels[grid.cell_of(3.9, 3.8)] != labels[0, 0]


def test_room_b_cylinder_is_drawn_in_place_with_its_radius() -> None:
    world = load_world("room_b")
    cylinder = next(o for o in world.obstacles if o.name == "cylinder")
    cx, cy = cylinder.pose.xyz[:2]
    grid = world_occupancy(world, resolution=0.05, conservative=False)
    x, y = grid.cell_centers()
    near = np.hypot(x - cx, y - cy) < 1.5
    occupied = grid.occupied & near
    assert np.hypot(x[occupied].mean() - cx, y[occupied].mean() - cy) < grid.resolution
    radius = np.sqrt(occupied.sum() / np.pi) * grid.resolution
    assert radius == pytest.approx(cylinder.geometry.radius, abs=grid.resolution)
    assert np.hypot(x[occupied] - cx, y[occupied] - cy).max() <= 0.5 + grid.resolution


def _one_box_world(pose: Pose, size=(2.0, 0.5, 1.0)) -> World:
    box = Obstacle("box", Box(size), pose)
    return World("one_box", obstacles=(box,))


def test_rotated_box_rasterizes_to_its_rotated_rectangle() -> None:
    yaw = np.deg2rad(30)
    pose = Pose.from_xy_yaw(1.0, 2.0, yaw, 0.5)
    world = _one_box_world(pose)
    res = 0.02
    exact = world_occupancy(world, resolution=res, conservative=False)
    cover = world_occupancy(world, resolution=res)
    for grid in (exact, cover):
        x, y = grid.cell_centers()
        u = (x - 1.0) * np.cos(yaw) + (y - 2.0) * np.sin(yaw)
        v = -(x - 1.0) * np.sin(yaw) + (y - 2.0) * np.cos(yaw)
        assert grid.occupied[(np.abs(u) < 1.0) & (np.abs(v) < 0.25)].all()
        assert not grid.occupied[(np.abs(u) > 1.0 + res) | (np.abs(v) > 0.25 + res)].any()
    assert exact.occupied.sum() * res**2 == pytest.approx(2.0 * 0.5, rel=0.03)
    assert cover.occupied.sum() > exact.occupied.sum()


@settings(max_examples=40, deadline=None)
@given(
    yaw=st.floats(-np.pi, np.pi),
    length=st.floats(0.05, 3.0),
    width=st.floats(0.05, 3.0),
    x=st.floats(-2.0, 2.0),
    y=st.floats(-2.0, 2.0),
)
def test_any_yawed_box_marks_exactly_the_cells_it_covers(yaw, length, width, x, y) -> None:
    world = _one_box_world(Pose.from_xy_yaw(x, y, yaw, 0.5), size=(length, width, 1.0))
    res = 0.05
    exact = world_occupancy(world, resolution=res, conservative=False)
    cover = world_occupancy(world, resolution=res, bounds=((-4, -4), (4, 4)))
    cx, cy = cover.cell_centers()
    u = np.abs((cx - x) * np.cos(yaw) + (cy - y) * np.sin(yaw))
    v = np.abs(-(cx - x) * np.sin(yaw) + (cy - y) * np.cos(yaw))
    assert cover.occupied[(u < length / 2 - 1e-6) & (v < width / 2 - 1e-6)].all()
    reach = res / np.sqrt(2)  # a cell touches the box only if its centre is this close
    assert not cover.occupied[(u > length / 2 + reach) | (v > width / 2 + reach)].any()
    ex, ey = exact.cell_centers()
    u = np.abs((ex - x) * np.cos(yaw) + (ey - y) * np.sin(yaw))
    v = np.abs(-(ex - x) * np.sin(yaw) + (ey - y) * np.cos(yaw))
    inside = (u < length / 2) & (v < width / 2)
    margin = (np.abs(u - length / 2) < 1e-6) | (np.abs(v - width / 2) < 1e-6)
    assert np.array_equal(exact.occupied[~margin], inside[~margin])


def test_height_band_cuts_bodies_and_tilted_shapes() -> None:
    low = _one_box_world(Pose((0, 0, 0.01)), size=(1, 1, 0.02))
    assert not world_occupancy(low).occupied.any(), "a mat under the band is not an obstacle"
    # a cylinder lying along x: its footprint is a 2 r x length rectangle
    lying = Obstacle("log", Cylinder(0.2, 1.5), Pose.from_xyz_rpy((0, 0, 0.3), (0, np.pi / 2, 0)))
    grid = world_occupancy(World("log", obstacles=(lying,)), resolution=0.02, conservative=False)
    assert grid.occupied.sum() * 0.02**2 == pytest.approx(0.4 * 1.5, rel=0.05)
    # a ball whose top just enters the band shows a small circle
    ball = Obstacle("ball", Sphere(0.1), Pose((0, 0, 0.0)))
    grid = world_occupancy(World("ball", obstacles=(ball,)), resolution=0.01, conservative=False)
    expected = np.pi * (0.1**2 - 0.05**2)
    assert grid.occupied.sum() * 0.01**2 == pytest.approx(expected, rel=0.1)


def test_bad_grid_arguments_are_refused() -> None:
    world = load_world("room_a")
    with pytest.raises(ModelError, match="resolution"):
        world_occupancy(world, resolution=0)
    with pytest.raises(ModelError, match="z_band"):
        world_occupancy(world, z_band=(1.0, 0.5))
