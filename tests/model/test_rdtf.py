"""RDTF: RobotModel -> .glb -> RobotModel keeps every field, and the Khronos glTF
validator accepts every file written (built-in robots, hand-built models, worlds)."""

from __future__ import annotations

import json
import math
import shutil
import subprocess
from dataclasses import replace
from pathlib import Path

import numpy as np
import pygltflib
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from robotrial.geometry import Box, Cylinder, Mesh, MeshData, Pose, Sphere
from robotrial.model import library, load_robot, load_world
from robotrial.model.rdtf import (
    RDTF_EXTENSION,
    rdtf_from_bytes,
    read_rdtf,
    write_rdtf,
)
from robotrial.model.robot import (
    Collision,
    CollisionSphere,
    Inertial,
    Joint,
    JointDynamics,
    JointLimit,
    Link,
    Material,
    Mimic,
    ModelError,
    RobotModel,
    Sensor,
    Visual,
)
from robotrial.model.scene_gltf import write_world_glb
from robotrial.model.world import Floor, Light, Obstacle, World

from .rdtf_compare import model_differences

ROOT = Path(__file__).resolve().parents[2]
VALIDATOR = ROOT / "tools" / "validate_gltf.mjs"


def validate(paths: list[Path]) -> dict[str, dict]:
    """Run the Khronos validator (tools/validate_gltf.mjs) once on all files."""
    node = shutil.which("node")
    assert node, "node is needed for the glTF validator (make setup installs it)"
    assert (ROOT / "tools" / "node_modules" / "gltf-validator").is_dir(), (
        "gltf-validator missing: run `make setup` (cd tools && npm ci)"
    )
    out = subprocess.run(
        [node, str(VALIDATOR), *map(str, paths)], capture_output=True, text=True, check=True
    )
    return {r["file"]: r for r in json.loads(out.stdout)}


def errors_of(report: dict) -> list[str]:
    """The validator's errors and warnings (infos are expected: unknown extensions)."""
    return [
        f"{m['severity']} {m['code']} {m['pointer']}: {m['message']}"
        for m in report["messages"]
        if m["severity"] in ("error", "warning")
    ]


def assert_same_model(a: RobotModel, b: RobotModel) -> None:
    differences = model_differences(a, b)
    assert differences == [], "\n".join(differences)


def hand_built(tmp_path: Path) -> RobotModel:
    """A robot using every RobotModel feature: all shapes, mesh files and in-memory
    meshes, rotated origins, mimic joints, sensors, spheres, metadata, repairs."""
    stl = tmp_path / "part.stl"
    trimesh.creation.annulus(r_min=0.01, r_max=0.03, height=0.05).export(stl)
    part = Mesh(str(stl), (0.5, 0.5, 2.0))
    tetra = MeshData(
        np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]], dtype=float) + 0.123456789,
        np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]),
    )
    odd = Pose.from_xyz_rpy((0.1, -0.2, 0.3), (0.3, -1.1, 2.9))
    links = (
        Link(
            "base",
            Inertial(2.5, Pose((0.01, 0.0, 0.05)), 0.1, 0.001, -0.002, 0.2, 0.003, 0.3),
            (Visual(Box((0.2, 0.3, 0.1)), Pose((0, 0, 0.05)), "grey", "body"),),
            (Collision(Box((0.2, 0.3, 0.1)), Pose((0, 0, 0.05)), "body"),),
        ),
        Link(
            "upper",
            Inertial(1.0 / 3.0, odd, 1e-3, 0.0, 0.0, 2e-3, 0.0, 3e-3),
            (
                Visual(Cylinder(0.04, 0.3), odd, "blue"),
                Visual(part, Pose.from_xyz_rpy((0, 0, 0.2), (math.pi / 2, 0, 0)), "red"),
                Visual(Mesh("", (1.0, 1.0, 1.0), tetra), Pose(), ""),
            ),
            (
                Collision(Cylinder(0.04, 0.3), odd),
                Collision(part, Pose((0, 0, 0.2))),
                Collision(Sphere(0.05), Pose((0.0, 0.0, 0.3))),
            ),
        ),
        Link("finger_a", Inertial(0.01), (Visual(Sphere(0.01), material="red"),)),
        Link(  # degenerate shapes, as messy files have them
            "finger_b",
            None,
            (Visual(Box((0.1, 0.0, 0.1))), Visual(Sphere(0.0))),
            (Collision(Box((0.1, 0.0, 0.1))), Collision(Cylinder(0.0, 0.1))),
        ),
        Link("tcp"),
    )
    joints = (
        Joint(
            "shoulder",
            "revolute",
            "base",
            "upper",
            Pose.from_xyz_rpy((0, 0, 0.1), (0, 0, 0.7)),
            (0.0, 0.6, 0.8),
            JointLimit(-2.9, 2.9, 12.5, 3.14159),
            JointDynamics(0.05, 0.01),
        ),
        Joint(
            "finger_a",
            "prismatic",
            "upper",
            "finger_a",
            Pose((0.0, 0.01, 0.31)),
            (0.0, 1.0, 0.0),
            JointLimit(0.0, 0.02, 5.0, 0.1),
        ),
        Joint(
            "finger_b",
            "prismatic",
            "upper",
            "finger_b",
            Pose((0.0, -0.01, 0.31)),
            (0.0, -1.0, 0.0),
            JointLimit(0.0, 0.02, 5.0, 0.1),
            mimic=Mimic("finger_a", -1.0, 0.001),
        ),
        Joint(
            "wrist_spin",
            "continuous",
            "upper",
            "tcp",
            odd,
            (0.0, 0.0, 1.0),
            JointLimit(-math.inf, math.inf, 1.5, 6.0),
        ),
    )
    return RobotModel(
        name="hand_built",
        links=links,
        joints=joints,
        materials={
            "grey": Material("grey", (0.5, 0.5, 0.5, 1.0)),
            "blue": Material("blue", (0.1, 0.2, 0.9, 0.5)),
            "red": Material("red", (0.9, 0.1, 0.1, 1.0), "textures/red.png"),
        },
        sensors=(
            Sensor(
                "lidar",
                "lidar",
                "base",
                Pose((0.0, 0.0, 0.2)),
                10.0,
                {"rings": 16, "vertical_min": -0.26, "range_max": 100.0, "model": "VLP-16"},
            ),
            Sensor("cam", "camera", "tcp", odd, 30.0, {"width": 640, "fov": 0.9}),
        ),
        spheres=(CollisionSphere("upper", (0.0, 0.0, 0.1), 0.05),),
        tcp="tcp",
        metadata={
            "groups": {"arm": ["shoulder"]},
            "gripper": {"joints": ["finger_a"], "open": 0.02, "closed": 0.0, "link": "upper"},
            "drive": {"type": "skid_steer", "max_speed": 1.0},
            "home": (0.0, 0.1),
        },
        source="/somewhere/hand_built.urdf",
        repairs=("link finger_a: inertia was zero; set to a small sphere",),
    )


def test_hand_built_model_round_trips_exactly(tmp_path):
    model = hand_built(tmp_path)
    out = tmp_path / "hand.glb"
    data = write_rdtf(model, out)
    assert out.read_bytes() == data
    back = read_rdtf(out)
    assert_same_model(model, back)
    # the same model always gives the same bytes, and a file read back writes itself
    assert write_rdtf(model) == data
    again = write_rdtf(back)
    assert write_rdtf(rdtf_from_bytes(again)) == again


def test_node_tree_follows_the_kinematic_tree(tmp_path):
    model = hand_built(tmp_path)
    gltf = pygltflib.GLTF2.load_from_bytes(write_rdtf(model))
    nodes = gltf.nodes
    by_name = {n.name: i for i, n in enumerate(nodes)}
    scene = gltf.scenes[gltf.scene]
    assert [nodes[i].name for i in scene.nodes] == ["base"]
    for j in model.joints:
        parent, child = nodes[by_name[j.parent]], nodes[by_name[j.child]]
        assert by_name[j.child] in parent.children
        t = child.translation or [0.0, 0.0, 0.0]
        r = child.rotation or [0.0, 0.0, 0.0, 1.0]
        assert np.allclose(Pose(t, r).matrix(), j.origin.matrix(), atol=1e-12)
    upper = nodes[by_name["upper"]]
    assert {nodes[c].name for c in upper.children} >= {
        "upper/visual/0",
        "upper/visual/1",
        "upper/visual/2",
        "upper/collision/0",
    }
    assert nodes[by_name["upper/visual/1"]].scale == [0.5, 0.5, 2.0]
    ext = gltf.extensions[RDTF_EXTENSION]
    assert ext["name"] == "hand_built" and ext["tcp"] == "tcp"
    j = next(j for j in ext["joints"] if j["name"] == "finger_b")
    assert j["mimic"] == {"joint": "finger_a", "multiplier": -1.0, "offset": 0.001}
    assert set(gltf.extensionsUsed) == {
        RDTF_EXTENSION,
        "KHR_physics_rigid_bodies",
        "KHR_implicit_shapes",
    }


def test_physics_extensions_describe_mass_and_colliders(tmp_path):
    model = hand_built(tmp_path)
    gltf = pygltflib.GLTF2.load_from_bytes(write_rdtf(model))
    by_name = {n.name: n for n in gltf.nodes}
    motion = by_name["base"].extensions["KHR_physics_rigid_bodies"]["motion"]
    assert motion["mass"] == 2.5
    assert motion["centerOfMass"] == [0.01, 0.0, 0.05]
    # the principal moments rebuild the URDF inertia tensor
    rot = pygltflib_quat_matrix(motion["inertiaOrientation"])
    tensor = rot @ np.diag(motion["inertiaDiagonal"]) @ rot.T
    assert np.allclose(tensor, model.link("base").inertial.tensor(), atol=1e-12)
    shapes = gltf.extensions["KHR_implicit_shapes"]["shapes"]
    collider = by_name["upper/collision/0"].extensions["KHR_physics_rigid_bodies"]["collider"]
    shape = shapes[collider["geometry"]["shape"]]
    assert shape["type"] == "cylinder"
    assert shape["cylinder"] == {"height": 0.3, "radiusTop": 0.04, "radiusBottom": 0.04}
    mesh_col = by_name["upper/collision/1"].extensions["KHR_physics_rigid_bodies"]["collider"]
    holder = gltf.nodes[mesh_col["geometry"]["node"]]
    assert holder.mesh is not None and holder.scale == [0.5, 0.5, 2.0]


def test_physics_joints_constrain_the_joint_axis(tmp_path):
    model = hand_built(tmp_path)
    gltf = pygltflib.GLTF2.load_from_bytes(write_rdtf(model))
    nodes = gltf.nodes
    index = {n.name: i for i, n in enumerate(nodes)}

    def local(i: int) -> np.ndarray:
        n = nodes[i]
        return Pose(n.translation or (0, 0, 0), n.rotation or (0, 0, 0, 1)).matrix()

    parent_of = {c: i for i, n in enumerate(nodes) for c in (n.children or [])}

    def world(i: int) -> np.ndarray:
        m = local(i)
        while i in parent_of:
            i = parent_of[i]
            m = local(i) @ m
        return m

    joints = gltf.extensions["KHR_physics_rigid_bodies"]["physicsJoints"]
    shoulder = model.joint("shoulder")
    ext = nodes[index["shoulder/joint"]].extensions["KHR_physics_rigid_bodies"]["joint"]
    assert ext["connectedNode"] == index["shoulder/joint/child"]
    assert parent_of[index["shoulder/joint"]] == index["base"]
    assert parent_of[index["shoulder/joint/child"]] == index["upper"]
    # at q = 0 both attachment frames coincide, and their x is the joint axis
    a, b = world(index["shoulder/joint"]), world(index["shoulder/joint/child"])
    assert np.allclose(a, b, atol=1e-12)
    axis_in_base = shoulder.origin.rotation() @ np.array(shoulder.axis)
    assert np.allclose(a[:3, 0], axis_in_base / np.linalg.norm(axis_in_base))
    spec = joints[ext["joint"]]
    assert {"angularAxes": [0], "min": -2.9, "max": 2.9} in spec["limits"]
    assert spec["drives"][0]["damping"] == 0.05
    finger = joints[
        nodes[index["finger_a/joint"]].extensions["KHR_physics_rigid_bodies"]["joint"]["joint"]
    ]
    assert {"linearAxes": [0], "min": 0.0, "max": 0.02} in finger["limits"]
    spin = joints[
        nodes[index["wrist_spin/joint"]].extensions["KHR_physics_rigid_bodies"]["joint"]["joint"]
    ]
    assert not any(lim.get("angularAxes") == [0] for lim in spin["limits"])


def pygltflib_quat_matrix(q) -> np.ndarray:
    return Pose((0, 0, 0), q).rotation()


def test_builtin_robots_and_worlds_validate_and_robots_round_trip(tmp_path):
    names = library.robot_names()
    assert names, "no built-in robots found"
    paths = []
    for name in names:
        model = load_robot(name)
        path = tmp_path / f"{name}.glb"
        write_rdtf(model, path)
        assert_same_model(model, read_rdtf(path))
        paths.append(path)
    hand = tmp_path / "hand.glb"
    write_rdtf(hand_built(tmp_path), hand)
    paths.append(hand)
    for name in [*library.world_names(), "lit"]:
        world = lit_world(tmp_path) if name == "lit" else load_world(name)
        path = tmp_path / f"world_{name}.glb"
        write_world_glb(world, path)
        paths.append(path)
    reports = validate(paths)
    for p in paths:
        assert errors_of(reports[str(p)]) == [], p.name


def test_reading_bad_files_names_the_problem(tmp_path):
    junk = tmp_path / "junk.glb"
    junk.write_bytes(b"not a glb at all")
    with pytest.raises(ModelError, match=r"junk\.glb: not a glTF binary"):
        read_rdtf(junk)
    plain = pygltflib.GLTF2(asset=pygltflib.Asset(version="2.0"), scenes=[pygltflib.Scene()])
    with pytest.raises(ModelError, match="no RDTF_robot extension"):
        rdtf_from_bytes(b"".join(plain.save_to_bytes()), "plain.glb")
    with pytest.raises(ModelError, match=r"missing\.glb: cannot read"):
        read_rdtf(tmp_path / "missing.glb")


def lit_world(tmp_path: Path) -> World:
    """A small world with every kind of body, a mesh obstacle and both kinds of light."""
    stl = tmp_path / "vase.stl"
    trimesh.creation.cone(radius=100.0, height=300.0).export(stl)
    return World(
        name="lit",
        floor=Floor(size=(4.0, 3.0), center=(1.0, 0.5), rgba=(0.8, 0.8, 0.8, 1.0)),
        walls=(Obstacle("north", Box((4.0, 0.1, 1.0)), Pose((1.0, 2.0, 0.5)), kind="wall"),),
        obstacles=(
            Obstacle("pillar", Cylinder(0.2, 1.5), Pose.from_xy_yaw(0.5, 0.5, 0.3, 0.75)),
            Obstacle("ball", Sphere(0.3), Pose((2.0, 0.0, 0.3)), rgba=(1.0, 0.0, 0.0, 0.5)),
            Obstacle("vase", Mesh(str(stl), (0.001, 0.001, 0.001)), Pose((0.0, 1.0, 0.0))),
        ),
        objects=(Obstacle("cup", Box((0.08, 0.08, 0.1)), Pose((1.0, 1.0, 0.05)), mass=0.2),),
        lights=(
            Light("sun", "directional", direction=(0.3, -0.2, -1.0), intensity=2.0),
            Light("lamp", "point", Pose((1.0, 1.0, 2.5)), color=(1.0, 0.9, 0.8)),
        ),
        spawns={"default": Pose.from_xy_yaw(0.5, 0.5, 1.0)},
    )


def world_node_corners(path: Path) -> dict[str, np.ndarray]:
    """World-space bounding boxes of every drawn node, by glTF node name (read with
    trimesh, an independent glTF reader, so node transforms are checked too)."""
    scene = trimesh.load(str(path), force="scene")
    out = {}
    for node in scene.graph.nodes_geometry:
        transform, geom = scene.graph[node]
        out[node] = trimesh.transform_points(scene.geometry[geom].vertices, transform)
    return out


def test_world_glb_places_every_body_and_light(tmp_path):
    world = lit_world(tmp_path)
    path = tmp_path / "lit.glb"
    write_world_glb(world, path)
    gltf = pygltflib.GLTF2.load(str(path))
    names = {n.name: n for n in gltf.nodes}
    for name in ("floor", "wall/north", "obstacle/pillar", "obstacle/ball", "object/cup"):
        assert name in names
    assert names["object/cup"].extensions["KHR_physics_rigid_bodies"]["motion"]["mass"] == 0.2
    assert names["obstacle/pillar"].extras["shape"] == "cylinder"
    lights = gltf.extensions["KHR_lights_punctual"]["lights"]
    assert [li["type"] for li in lights] == ["directional", "point"]
    sun = names["light/sun"]
    # a directional light shines along its node's -z: that must be the world direction
    shine = Pose((0, 0, 0), sun.rotation).rotation() @ [0.0, 0.0, -1.0]
    assert np.allclose(shine, np.array([0.3, -0.2, -1.0]) / np.linalg.norm([0.3, -0.2, -1.0]))
    corners = world_node_corners(path)
    wall = corners["wall/north"]
    assert np.allclose(wall.min(axis=0), [-1.0, 1.95, 0.0], atol=1e-6)
    assert np.allclose(wall.max(axis=0), [3.0, 2.05, 1.0], atol=1e-6)
    pillar = corners["obstacle/pillar"]
    assert np.allclose(pillar[:, 2].min(), 0.0, atol=1e-6)
    assert np.allclose(pillar[:, 2].max(), 1.5, atol=1e-6)
    floor = corners["floor"]
    assert np.allclose(floor.min(axis=0), [-1.0, -1.0, 0.0]) and np.allclose(
        floor.max(axis=0), [3.0, 2.0, 0.0]
    )
    vase = corners["obstacle/vase"]  # millimetre file, scaled by the node
    assert np.allclose(vase[:, 2].max() - vase[:, 2].min(), 0.3, atol=1e-6)
    assert names["obstacle/vase"].scale == [0.001, 0.001, 0.001]
    assert gltf.extras["world"]["spawns"]["default"]["xyz"] == [0.5, 0.5, 0.0]


def test_differences_are_found_and_named(tmp_path):
    model = hand_built(tmp_path)
    back = rdtf_from_bytes(write_rdtf(model))
    shoulder = back.joint("shoulder")
    nudged = shoulder.limit.upper + 1e-15  # one float64 step matters
    changed = back.with_changes(
        joints=tuple(
            replace(j, limit=replace(j.limit, upper=nudged)) if j.name == "shoulder" else j
            for j in back.joints
        ),
        sensors=(replace(back.sensors[0], params={**back.sensors[0].params, "rings": 32}),),
        tcp="upper",
    )
    found = model_differences(model, changed)
    assert any(d.startswith("joint shoulder") for d in found)
    assert any(d.startswith("sensor names") for d in found)
    assert any(d.startswith("tcp") for d in found)


finite = st.floats(-10.0, 10.0, allow_nan=False)
positive = st.floats(1e-3, 5.0, allow_nan=False)
shapes = st.one_of(
    st.builds(Box, st.tuples(positive, positive, positive)),
    st.builds(Cylinder, positive, positive),
    st.builds(Sphere, positive),
)
poses = st.builds(
    Pose.from_xyz_rpy,
    st.tuples(finite, finite, finite),
    st.tuples(finite, finite, finite),
)


@st.composite
def random_robots(draw) -> RobotModel:
    """Random trees: each new link hangs from an earlier one by a random joint."""
    n = draw(st.integers(1, 6))
    links, joints = [], []
    for i in range(n):
        inertial = draw(
            st.none() | st.builds(Inertial, positive, poses, positive, finite, finite, positive)
        )
        visuals = tuple(
            Visual(g, p, "m" if draw(st.booleans()) else "")
            for g, p in draw(st.lists(st.tuples(shapes, poses), max_size=2))
        )
        collisions = tuple(
            Collision(g, p) for g, p in draw(st.lists(st.tuples(shapes, poses), max_size=2))
        )
        links.append(Link(f"l{i}", inertial, visuals, collisions))
        if i:
            kind = draw(st.sampled_from(["revolute", "continuous", "prismatic", "fixed"]))
            lo = draw(finite)
            limit = JointLimit(lo, lo + draw(positive), draw(positive), draw(positive))
            axis = draw(st.tuples(finite, finite, finite).filter(lambda a: any(a)))
            joints.append(
                Joint(
                    f"j{i}",
                    kind,
                    f"l{draw(st.integers(0, i - 1))}",
                    f"l{i}",
                    draw(poses),
                    axis,
                    None if kind == "continuous" else limit,
                    draw(st.none() | st.builds(JointDynamics, positive, positive)),
                )
            )
    return RobotModel(
        "random",
        tuple(links),
        tuple(joints),
        materials={"m": Material("m", (0.2, 0.4, 0.6, 1.0))},
    )


@settings(max_examples=25, deadline=None)
@given(random_robots())
def test_random_robots_round_trip_exactly(model):
    data = write_rdtf(model)
    assert model_differences(model, rdtf_from_bytes(data)) == []


def test_reads_the_json_form_other_tools_make(tmp_path):
    """A .glb re-saved as .gltf (JSON with an external buffer) by another tool reads back."""
    model = hand_built(tmp_path)
    glb = tmp_path / "hand.glb"
    write_rdtf(model, glb)
    gltf = pygltflib.GLTF2.load(str(glb))
    gltf.convert_buffers(pygltflib.BufferFormat.BINFILE)
    gltf.save(str(tmp_path / "hand.gltf"))
    assert model_differences(model, read_rdtf(tmp_path / "hand.gltf")) == []
