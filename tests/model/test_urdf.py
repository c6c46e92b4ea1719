"""URDF/xacro loader: every field mapped, repairs recorded, bad files refused with a location."""

from __future__ import annotations

import json
import math
import re
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from robotrial.cli import main as cli_main
from robotrial.geometry import Box, Cylinder, Mesh, Sphere
from robotrial.model import load_robot
from robotrial.model.meshes import load_mesh
from robotrial.model.packages import PackageResolver, ResourceNotFound
from robotrial.model.robot import ModelError
from robotrial.model.urdf import (
    URDFRepairWarning,
    load_urdf,
    nearest_valid_inertia,
    urdf_from_string,
)

INERTIAL = '<inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"/></inertial>'


def robot(body: str, name: str = "r") -> str:
    return f'<?xml version="1.0"?>\n<robot name="{name}">\n{body}\n</robot>\n'


def two_links(joint: str = "", child_extra: str = INERTIAL) -> str:
    return robot(
        f"""<link name="base"/>
<link name="arm">{child_extra}</link>
{
            joint
            or '<joint name="j" type="revolute"><parent link="base"/><child link="arm"/>'
            '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        }"""
    )


def load_quiet(text: str, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", URDFRepairWarning)
        return urdf_from_string(text, **kw)


@pytest.fixture
def cube_stl(tmp_path: Path) -> Path:
    path = tmp_path / "meshes" / "cube.stl"
    path.parent.mkdir()
    trimesh.creation.box(extents=(0.1, 0.2, 0.3)).export(path)
    return path


# --- every field ---------------------------------------------------------------------------

FULL = (
    """<?xml version="1.0"?>
<robot name="full">
  <material name="blue"><color rgba="0 0 1 1"/></material>
  <material name="wood"><texture filename="meshes/wood.png"/></material>
  <link name="base">
    <inertial>
      <origin xyz="0 0 0.1" rpy="0 0 0"/>
      <mass value="2.5"/>
      <inertia ixx="0.02" ixy="0.001" ixz="0" iyy="0.03" iyz="0" izz="0.04"/>
    </inertial>
    <visual name="body">
      <origin xyz="0 0 0.05" rpy="0 0 1.5707963"/>
      <geometry><box size="0.2 0.3 0.1"/></geometry>
      <material name="blue"/>
    </visual>
    <visual>
      <geometry><mesh filename="meshes/cube.stl" scale="2 2 2"/></geometry>
      <material name="red"><color rgba="1 0 0 1"/></material>
    </visual>
    <visual>
      <geometry><sphere radius="0.05"/></geometry>
      <material><color rgba="0 1 0 0.5"/></material>
    </visual>
    <collision name="hull">
      <origin xyz="0 0 0.05"/>
      <geometry><cylinder radius="0.1" length="0.2"/></geometry>
    </collision>
    <collision>
      <geometry><mesh filename="package://fullpkg/meshes/cube.stl" scale="0.001"/></geometry>
    </collision>
  </link>
  <link name="l_rev">"""
    + INERTIAL
    + """</link>
  <link name="l_cont">"""
    + INERTIAL
    + """</link>
  <link name="l_pris">"""
    + INERTIAL
    + """</link>
  <link name="l_fix"/>
  <link name="l_float">"""
    + INERTIAL
    + """</link>
  <link name="l_plan">"""
    + INERTIAL
    + """</link>
  <link name="l_mimic">"""
    + INERTIAL
    + """</link>
  <link name="tcp"/>
  <joint name="rev" type="revolute">
    <origin xyz="0 0 0.2" rpy="0 0.5 0"/>
    <parent link="base"/><child link="l_rev"/>
    <axis xyz="0 0 1"/>
    <limit lower="-2" upper="2.5" effort="30" velocity="1.5"/>
    <dynamics damping="0.7" friction="0.1"/>
  </joint>
  <joint name="cont" type="continuous">
    <parent link="l_rev"/><child link="l_cont"/><axis xyz="0 1 0"/>
    <limit effort="5" velocity="3"/>
  </joint>
  <joint name="pris" type="prismatic">
    <parent link="l_cont"/><child link="l_pris"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="0.3" effort="100" velocity="0.2"/>
  </joint>
  <joint name="fix" type="fixed"><parent link="l_pris"/><child link="l_fix"/></joint>
  <joint name="float" type="floating"><parent link="base"/><child link="l_float"/></joint>
  <joint name="plan" type="planar">
    <parent link="base"/><child link="l_plan"/><axis xyz="0 0 1"/>
  </joint>
  <joint name="mim" type="prismatic">
    <parent link="l_pris"/><child link="l_mimic"/><axis xyz="0 1 0"/>
    <limit lower="-0.3" upper="0" effort="100" velocity="0.2"/>
    <mimic joint="pris" multiplier="-1" offset="0.01"/>
  </joint>
  <joint name="tcp_joint" type="fixed">
    <origin xyz="0 0 0.1"/><parent link="l_fix"/><child link="tcp"/>
  </joint>
  <robotrial>
    <tcp link="tcp"/>
    <group name="arm" joints="rev cont pris"/>
    <pose name="tucked" joints="rev pris" values="1.5 0.01"/>
    <gripper joints="pris" open="0.02" closed="0.0" link="l_fix"/>
    <drive type="skid_steer" max_speed="1.0" max_accel="1.0" max_yaw_rate="2.0"
           wheel_separation="0.555" wheel_radius="0.165"/>
    <sensor name="velodyne" type="lidar" link="l_fix" rate="10">
      <origin xyz="0 0 0.3" rpy="0 0 0"/>
      <param name="rings" value="16"/>
      <param name="range_max" value="100.0"/>
      <param name="frame" value="velodyne"/>
    </sensor>
    <sensor name="cam" type="camera" link="tcp"/>
    <sphere link="l_rev" center="0 0 0.05" radius="0.04"/>
  </robotrial>
</robot>
"""
)


@pytest.fixture
def full_model(tmp_path: Path, cube_stl: Path):
    (tmp_path / "meshes" / "wood.png").write_bytes(b"\x89PNG\r\n\x1a\n")
    (tmp_path / "package.xml").write_text("<package><name>fullpkg</name></package>")
    path = tmp_path / "full.urdf"
    path.write_text(FULL)
    with warnings.catch_warnings():
        warnings.simplefilter("error", URDFRepairWarning)
        return load_urdf(path)


def test_links_inertial_visuals_collisions(full_model, cube_stl: Path) -> None:
    m = full_model
    assert m.name == "full" and m.repairs == ()
    base = m.link("base")
    assert base.inertial.mass == 2.5
    assert base.inertial.origin.xyz == (0.0, 0.0, 0.1)
    assert (base.inertial.ixx, base.inertial.ixy, base.inertial.iyy, base.inertial.izz) == (
        0.02,
        0.001,
        0.03,
        0.04,
    )
    body, mesh_vis, sphere_vis = base.visuals
    assert body.name == "body" and body.geometry == Box((0.2, 0.3, 0.1))
    assert body.material == "blue"
    assert body.origin.xyz == (0.0, 0.0, 0.05)
    assert body.origin.yaw == pytest.approx(1.5707963)
    assert isinstance(mesh_vis.geometry, Mesh)
    assert Path(mesh_vis.geometry.filename) == cube_stl.resolve()
    assert mesh_vis.geometry.scale == (2.0, 2.0, 2.0)
    assert mesh_vis.material == "red"
    assert sphere_vis.geometry == Sphere(0.05)
    # an inline material without a name gets one, and lands in the materials table
    assert m.materials[sphere_vis.material].rgba == (0.0, 1.0, 0.0, 0.5)
    hull, mesh_col = base.collisions
    assert hull.name == "hull" and hull.geometry == Cylinder(0.1, 0.2)
    assert mesh_col.geometry.scale == (0.001, 0.001, 0.001)
    assert Path(mesh_col.geometry.filename) == cube_stl.resolve()


def test_materials(full_model, tmp_path: Path) -> None:
    mats = full_model.materials
    assert mats["blue"].rgba == (0.0, 0.0, 1.0, 1.0)
    assert mats["red"].rgba == (1.0, 0.0, 0.0, 1.0)
    assert Path(mats["wood"].texture) == (tmp_path / "meshes" / "wood.png").resolve()


def test_joints_all_types(full_model) -> None:
    m = full_model
    assert {j.type for j in m.joints} == {
        "revolute",
        "continuous",
        "prismatic",
        "fixed",
        "floating",
        "planar",
    }
    rev = m.joint("rev")
    assert (rev.parent, rev.child, rev.axis) == ("base", "l_rev", (0.0, 0.0, 1.0))
    assert rev.origin.xyz == (0.0, 0.0, 0.2) and rev.origin.rpy[1] == pytest.approx(0.5)
    assert (rev.limit.lower, rev.limit.upper, rev.limit.effort, rev.limit.velocity) == (
        -2.0,
        2.5,
        30.0,
        1.5,
    )
    assert (rev.dynamics.damping, rev.dynamics.friction) == (0.7, 0.1)
    assert m.joint("cont").limit.effort == 5.0
    assert m.joint("fix").limit is None
    mim = m.joint("mim").mimic
    assert (mim.joint, mim.multiplier, mim.offset) == ("pris", -1.0, 0.01)
    assert m.joint_names == ["rev", "cont", "pris"]
    assert m.total_mass == pytest.approx(2.5 + 6)


def test_robotrial_element(full_model) -> None:
    m = full_model
    assert m.tcp == "tcp" and m.end_effector == "tcp"
    assert m.metadata["groups"] == {"arm": ["rev", "cont", "pris"]}
    assert m.metadata["poses"] == {"tucked": {"rev": 1.5, "pris": 0.01}}
    assert m.metadata["gripper"] == {
        "joints": ["pris"],
        "open": 0.02,
        "closed": 0.0,
        "link": "l_fix",
    }
    drive = m.metadata["drive"]
    assert drive["type"] == "skid_steer" and drive["wheel_radius"] == 0.165
    assert drive["max_yaw_rate"] == 2.0
    lidar = m.sensor("velodyne")
    assert (lidar.type, lidar.link, lidar.rate_hz) == ("lidar", "l_fix", 10.0)
    assert lidar.origin.xyz == (0.0, 0.0, 0.3)
    assert lidar.params == {"rings": 16, "range_max": 100.0, "frame": "velodyne"}
    assert isinstance(lidar.params["rings"], int)
    assert m.sensor("cam").rate_hz == 10.0
    (sphere,) = m.spheres
    assert (sphere.link, sphere.center, sphere.radius) == ("l_rev", (0.0, 0.0, 0.05), 0.04)


def test_mesh_triangles_load_lazily_and_scaled(full_model) -> None:
    mesh = full_model.link("base").visuals[1].geometry
    assert mesh.data is None  # the loader only resolves the file
    data = load_mesh(mesh)
    assert len(data.faces) == 12
    extent = data.vertices.max(axis=0) - data.vertices.min(axis=0)
    np.testing.assert_allclose(extent, (0.2, 0.4, 0.6))
    raw = load_mesh(mesh, scaled=False)
    np.testing.assert_allclose(raw.vertices.max(axis=0) - raw.vertices.min(axis=0), (0.1, 0.2, 0.3))
    assert load_mesh(mesh, scaled=False) is raw  # cached per file


def test_builtin_robots_load_with_their_extension() -> None:
    from robotrial.model.library import robot_names

    for name in robot_names():
        m = load_robot(name)
        assert m.links and m.repairs == (), name


# --- repairs ------------------------------------------------------------------------------


def repaired(text: str, expect: str):
    with pytest.warns(URDFRepairWarning, match=re.escape(expect)):
        m = urdf_from_string(text)
    assert any(expect in r for r in m.repairs), m.repairs
    return m


def test_missing_inertial_on_moving_link_gets_box_inertia() -> None:
    text = two_links(
        child_extra='<collision><geometry><box size="0.1 0.2 0.3"/></geometry></collision>'
    )
    m = repaired(text, "link 'arm' moves but has no <inertial>")
    inertial = m.link("arm").inertial
    assert 0 < inertial.mass <= 1.0
    assert inertial.izz > 0 and inertial.ixx > inertial.izz  # a box taller than wide
    assert m.link("base").inertial is None  # the root does not move: left alone


def test_massless_link_with_massive_child_is_left_alone() -> None:
    text = robot(
        f"""<link name="base"/><link name="virtual"/><link name="leg">{INERTIAL}</link>
<joint name="a" type="continuous"><parent link="base"/><child link="virtual"/></joint>
<joint name="b" type="continuous"><parent link="virtual"/><child link="leg"/></joint>"""
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error", URDFRepairWarning)
        m = urdf_from_string(text)
    assert m.link("virtual").inertial is None and m.repairs == ()


def test_zero_and_negative_mass() -> None:
    zero = two_links(child_extra='<inertial><mass value="0"/></inertial>')
    assert repaired(zero, "link 'arm' moves but has zero mass").link("arm").inertial.mass > 0
    neg = two_links(
        child_extra='<inertial><mass value="-2"/><inertia ixx="1" iyy="1" izz="1"/></inertial>'
    )
    assert repaired(neg, "negative mass -2").link("arm").inertial.mass > 0


def test_inertia_breaking_triangle_inequality_is_fixed() -> None:
    text = two_links(
        child_extra='<inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.5"/></inertial>'
    )
    m = repaired(text, "link 'arm' (line 4): inertia with principal moments (0.1, 0.1, 0.5)")
    i = m.link("arm").inertial
    assert i.ixx + i.iyy >= i.izz - 1e-12
    assert (i.ixx, i.iyy, i.izz) == pytest.approx((0.2, 0.2, 0.4))
    assert i.ixy == pytest.approx(0.0, abs=1e-12)


def test_inertia_not_positive_definite_is_fixed() -> None:
    text = two_links(
        child_extra='<inertial><mass value="1"/>'
        '<inertia ixx="1e-6" ixy="1e-6" ixz="1e-6" iyy="1e-6" iyz="1e-6" izz="1e-6"/></inertial>'
    )
    m = repaired(text, "is not positive definite")
    assert np.all(np.linalg.eigvalsh(m.link("arm").inertial.tensor()) > 0)


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.floats(-1.0, 1.0), min_size=6, max_size=6),
    st.floats(0.0, 10.0),
)
def test_nearest_valid_inertia_is_always_physical(values, mass) -> None:
    ixx, ixy, ixz, iyy, iyz, izz = values
    t = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    fixed = nearest_valid_inertia(t, mass)
    result = t if fixed is None else fixed
    w = np.linalg.eigvalsh(result)
    assert w[0] > 0
    assert w[0] + w[1] >= w[2] * (1 - 1e-9)


def test_joint_repairs() -> None:
    swapped = two_links(
        '<joint name="j" type="revolute"><parent link="base"/><child link="arm"/>'
        '<limit lower="1" upper="-1" effort="1" velocity="1"/></joint>'
    )
    lim = repaired(swapped, "joint 'j' (line 5): lower limit 1.0 > upper -1.0").joint("j").limit
    assert (lim.lower, lim.upper) == (-1.0, 1.0)
    no_limit = two_links(
        '<joint name="j" type="revolute"><parent link="base"/><child link="arm"/></joint>'
    )
    lim = repaired(no_limit, "joint 'j' (line 5): revolute joint has no <limit>").joint("j").limit
    assert (lim.lower, lim.upper) == (-math.pi, math.pi)
    zero_axis = two_links(
        '<joint name="j" type="continuous"><parent link="base"/><child link="arm"/>'
        '<axis xyz="0 0 0"/></joint>'
    )
    assert repaired(zero_axis, "joint 'j': axis (0.0, 0.0, 0.0) has zero length").joint(
        "j"
    ).axis == (1.0, 0.0, 0.0)
    long_axis = two_links(
        '<joint name="j" type="continuous"><parent link="base"/><child link="arm"/>'
        '<axis xyz="0 0 2"/></joint>'
    )
    assert repaired(long_axis, "normalised").joint("j").axis == (0.0, 0.0, 1.0)


def test_mimic_of_missing_joint_is_dropped() -> None:
    text = two_links(
        '<joint name="j" type="continuous"><parent link="base"/><child link="arm"/>'
        '<mimic joint="ghost"/></joint>'
    )
    m = repaired(text, "joint 'j' (line 5) mimics joint 'ghost', which does not exist")
    assert m.joint("j").mimic is None and m.joint_names == ["j"]


def test_missing_visual_mesh_is_dropped_and_undefined_material_is_grey() -> None:
    text = two_links(
        child_extra=INERTIAL
        + '<visual><geometry><mesh filename="package://nowhere/a.stl"/></geometry></visual>'
        + '<visual><geometry><sphere radius="0.1"/></geometry><material name="Gazebo/Red"/>'
        "</visual>"
    )
    with pytest.warns(URDFRepairWarning):
        m = urdf_from_string(text)
    assert len(m.link("arm").visuals) == 1
    assert any(
        "link 'arm' visual 0: mesh 'package://nowhere/a.stl' dropped" in r for r in m.repairs
    )
    assert m.materials["Gazebo/Red"].rgba == (0.7, 0.7, 0.7, 1.0)


def test_unexpanded_xacro_in_urdf_is_expanded() -> None:
    text = """<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">
<xacro:property name="w" value="0.5"/>
<link name="base"><visual><geometry><box size="${w} ${w*2} 1"/></geometry></visual></link>
</robot>"""
    m = repaired(text, "expanded with xacro")
    assert m.link("base").visuals[0].geometry == Box((0.5, 1.0, 1.0))


# --- errors -------------------------------------------------------------------------------


def refused(text: str, *needles: str, **kw) -> str:
    with pytest.raises(ModelError) as info:
        load_quiet(text, **kw)
    msg = str(info.value)
    for n in needles:
        assert n in msg, msg
    return msg


def test_not_xml_names_the_line() -> None:
    refused('<robot name="r">\n<link name="a">\n</robot>', "<string>:3", "not well-formed XML")


def test_no_robot_element() -> None:
    refused("<sdf><model/></sdf>", "<string>:1", "root element is <sdf>, expected <robot>")
    refused(robot(""), "has no <link>")


def test_joint_referencing_missing_link() -> None:
    text = two_links(
        '<joint name="j" type="fixed"><parent link="base"/><child link="hand"/></joint>'
    )
    refused(text, "<string>:5", "<joint name='j'>", "child link 'hand' does not exist")


def test_unknown_joint_type() -> None:
    text = two_links('<joint name="j" type="ball"><parent link="base"/><child link="arm"/></joint>')
    refused(text, "<string>:5", "<joint name='j'>", "unknown joint type 'ball'")


def test_two_roots_and_cycles() -> None:
    refused(robot('<link name="a"/><link name="b"/>'), "2 separate trees", "['a', 'b']")
    cycle = robot(
        """<link name="root"/><link name="a"/><link name="b"/>
<joint name="ab" type="fixed"><parent link="a"/><child link="b"/></joint>
<joint name="ba" type="fixed"><parent link="b"/><child link="a"/></joint>"""
    )
    refused(cycle, "cycle")
    two_parents = robot(
        """<link name="a"/><link name="b"/><link name="c"/>
<joint name="ac" type="fixed"><parent link="a"/><child link="c"/></joint>
<joint name="bc" type="fixed"><parent link="b"/><child link="c"/></joint>"""
    )
    refused(two_parents, "<string>:5", "link 'c' already has parent joint 'ac' (line 4)")


def test_bad_geometry_and_numbers() -> None:
    neg = two_links(child_extra='<visual><geometry><box size="1 -1 1"/></geometry></visual>')
    refused(neg, "<string>:4", "<box>", "link 'arm' visual 0: size (1.0, -1.0, 1.0) is negative")
    bad = two_links(child_extra='<visual><geometry><sphere radius="big"/></geometry></visual>')
    refused(bad, "<sphere>", "radius='big' is not 1 number(s)")
    empty = two_links(child_extra="<collision><geometry/></collision>")
    refused(empty, "collision 0 of link 'arm'", "<geometry> holds no shape")


def test_duplicates() -> None:
    refused(
        robot('<link name="a"/>\n<link name="a"/>'), "<string>:4", "defined twice (first at line 3)"
    )


def test_prismatic_without_limit() -> None:
    text = two_links(
        '<joint name="j" type="prismatic"><parent link="base"/><child link="arm"/></joint>'
    )
    refused(text, "<joint name='j'>", "prismatic joint has no <limit>")


def test_missing_collision_mesh_is_an_error(tmp_path: Path) -> None:
    text = two_links(
        child_extra=INERTIAL
        + '<collision><geometry><mesh filename="package://ghost_pkg/hull.stl"/></geometry>'
        "</collision>"
    )
    msg = refused(
        text,
        "link 'arm' collision 0",
        "'package://ghost_pkg/hull.stl'",
        f"package 'ghost_pkg' not found in {tmp_path}",
        "--package-path",
        base_dir=tmp_path,
    )
    assert "<string>:4" in msg


def test_robotrial_element_errors() -> None:
    base = two_links().replace("</robot>", "<robotrial>{}</robotrial>\n</robot>")
    refused(base.format('<tcp link="hand"/>'), "<tcp>", "link 'hand' does not exist")
    refused(
        base.format('<sensor name="s" type="sonar" link="arm"/>'),
        "<sensor name='s'>",
        "unknown sensor type 'sonar'",
    )
    refused(base.format('<group name="g" joints="j nope"/>'), "joints ['nope'] do not exist")
    refused(base.format('<sphere link="arm" center="0 0" radius="1"/>'), "center='0 0' has 2")
    refused(base.format("<teleport/>"), "unknown element <teleport> in <robotrial>")
    refused(base.format('<drive max_speed="1"/>'), "<drive> has no type")
    refused(base.format('<pose name="p" joints="j" values="1 2"/>'), "values='1 2' has 2")
    refused(base.format('<pose name="p" joints="nope" values="1"/>'), "joints ['nope'] do not")


# --- xacro and packages -------------------------------------------------------------------


def make_package(root: Path, name: str, folder: str) -> Path:
    pkg = root / folder
    (pkg / "meshes").mkdir(parents=True)
    (pkg / "package.xml").write_text(f"<package format='3'>\n  <name>{name}</name>\n</package>")
    trimesh.creation.box(extents=(1, 1, 1)).export(pkg / "meshes" / "part.stl")
    return pkg


def test_xacro_macro_property_and_find(tmp_path: Path) -> None:
    pkg = make_package(tmp_path / "src", "my_robot_description", "description")
    (pkg / "urdf").mkdir()
    (pkg / "urdf" / "parts.xacro").write_text(
        """<robot xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:property name="seg_len" value="0.4"/>
  <xacro:macro name="segment" params="name parent">
    <link name="${name}">
      <inertial><mass value="${seg_len * 5}"/><inertia ixx="0.1" iyy="0.1" izz="0.1"/></inertial>
      <collision><geometry><mesh filename="package://my_robot_description/meshes/part.stl"/>
      </geometry></collision>
    </link>
    <joint name="${name}_joint" type="revolute">
      <parent link="${parent}"/><child link="${name}"/>
      <origin xyz="0 0 ${seg_len}"/>
      <limit lower="${-pi/2}" upper="${pi/2}" effort="1" velocity="1"/>
    </joint>
  </xacro:macro>
</robot>"""
    )
    main = pkg / "urdf" / "arm.urdf.xacro"
    main.write_text(
        """<?xml version="1.0"?>
<robot name="arm" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:arg name="prefix" default="a_"/>
  <xacro:include filename="$(find my_robot_description)/urdf/parts.xacro"/>
  <link name="base"/>
  <xacro:segment name="$(arg prefix)upper" parent="base"/>
  <xacro:segment name="$(arg prefix)lower" parent="$(arg prefix)upper"/>
</robot>"""
    )
    m = load_urdf(main)
    assert [j.name for j in m.joints] == ["a_upper_joint", "a_lower_joint"]
    assert m.joint("a_lower_joint").origin.xyz == (0.0, 0.0, 0.4)
    assert m.joint("a_upper_joint").limit.upper == pytest.approx(math.pi / 2)
    assert m.link("a_upper").inertial.mass == pytest.approx(2.0)
    assert (
        Path(m.link("a_upper").collisions[0].geometry.filename)
        == (pkg / "meshes" / "part.stl").resolve()
    )
    m2 = load_urdf(main, xacro_args={"prefix": "b_"})
    assert m2.joint_names == ["b_upper_joint", "b_lower_joint"]


def test_xacro_failure_is_a_model_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.xacro"
    bad.write_text(
        '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<link name="${undefined_thing}"/></robot>'
    )
    with pytest.raises(ModelError, match=r"bad.xacro: xacro expansion failed: .*undefined_thing"):
        load_urdf(bad)


def test_package_found_through_package_xml_above_the_file(tmp_path: Path) -> None:
    # the folder is "description" but package.xml says the package is "fancy_bot"
    pkg = make_package(tmp_path, "fancy_bot", "description")
    resolver = PackageResolver.create(pkg / "urdf")
    assert (
        resolver.resolve("package://fancy_bot/meshes/part.stl")
        == (pkg / "meshes" / "part.stl").resolve()
    )
    assert resolver.resolve("package:///fancy_bot/meshes/part.stl").name == "part.stl"


def test_package_paths_and_ros_package_path(tmp_path: Path, monkeypatch) -> None:
    ws = tmp_path / "ws" / "src"
    pkg = make_package(ws, "other_pkg", "other_pkg")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    with pytest.raises(ResourceNotFound, match="package 'other_pkg' not found"):
        PackageResolver.create(elsewhere, use_environment=False).resolve(
            "package://other_pkg/meshes/part.stl"
        )
    explicit = PackageResolver.create(elsewhere, [tmp_path / "ws"], use_environment=False)
    assert explicit.resolve("package://other_pkg/meshes/part.stl").parent == pkg / "meshes"
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"/does/not/exist:{ws}")
    env = PackageResolver.create(elsewhere)
    assert env.resolve("package://other_pkg/meshes/part.stl").parent == pkg / "meshes"


def test_file_uri_and_relative_paths(tmp_path: Path, cube_stl: Path) -> None:
    r = PackageResolver.create(tmp_path, use_environment=False)
    assert r.resolve(f"file://{cube_stl}") == cube_stl.resolve()
    assert r.resolve("meshes/cube.stl") == cube_stl.resolve()
    with pytest.raises(ResourceNotFound) as info:
        r.resolve("meshes/missing.stl")
    assert str(tmp_path / "meshes" / "missing.stl") in str(info.value)
    with pytest.raises(ResourceNotFound, match="unsupported scheme"):
        r.resolve("http://example.com/a.stl")


# --- robotrial info -----------------------------------------------------------------------


def test_info_json(full_model, tmp_path: Path, capsys) -> None:
    assert cli_main(["info", "--robot", str(tmp_path / "full.urdf"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["name"] == "full" and out["dof"] == 3
    assert out["end_effector"] == "tcp"
    assert out["total_mass"] == pytest.approx(8.5)
    assert {s["name"] for s in out["sensors"]} == {"velodyne", "cam"}
    rev = next(j for j in out["joints"] if j["name"] == "rev")
    assert rev["limit"]["upper"] == 2.5 and rev["type"] == "revolute"
    assert out["repairs"] == []


def test_info_table_lists_repairs(tmp_path: Path, capsys) -> None:
    path = tmp_path / "r.urdf"
    path.write_text(
        two_links(
            '<joint name="j" type="revolute"><parent link="base"/><child link="arm"/></joint>'
        )
    )
    assert cli_main(["info", "--robot", str(path)]) == 0
    out = capsys.readouterr().out
    assert "DOF 1" in out and "revolute joint has no <limit>" in out


def test_info_bad_input_is_one_line(tmp_path: Path, capsys) -> None:
    path = tmp_path / "broken.urdf"
    path.write_text('<robot name="r">\n<link name="a"/>\n<joint name="j" type="fixed"/>\n</robot>')
    assert cli_main(["info", "--robot", str(path)]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert f"{path}:3" in err and "<joint name='j'>" in err
    assert cli_main(["info", "--robot", "no_such_robot"]) == 1
    assert "unknown robot 'no_such_robot'" in capsys.readouterr().err


# --- mesh files -----------------------------------------------------------------------------


def box_dae(tmp_path: Path, name: str, unit: str = "", broken_material: bool = False) -> Path:
    text = trimesh.exchange.dae.export_collada(trimesh.creation.box(extents=(1, 2, 3))).decode()
    if unit:
        text = text.replace("<asset>", f'<asset><unit name="mm" meter="{unit}"/>', 1)
    if broken_material:
        text = re.sub(r'(<instance_material symbol="[^"]*" target=")#[^"]*"', r'\1#gone"', text)
    path = tmp_path / name
    path.write_text(text)
    return path


def extents(mesh: Mesh) -> np.ndarray:
    v = load_mesh(mesh).vertices
    return v.max(axis=0) - v.min(axis=0)


def test_mesh_formats_and_collada_units(tmp_path: Path) -> None:
    box = trimesh.creation.box(extents=(1, 2, 3))
    box.export(tmp_path / "b.obj")
    box.export(tmp_path / "b.stl")
    np.testing.assert_allclose(extents(Mesh(str(tmp_path / "b.obj"))), (1, 2, 3))
    np.testing.assert_allclose(extents(Mesh(str(tmp_path / "b.stl"), (1, 1, 2))), (1, 2, 6))
    np.testing.assert_allclose(extents(Mesh(str(box_dae(tmp_path, "m.dae")))), (1, 2, 3))
    mm = Mesh(str(box_dae(tmp_path, "mm.dae", unit="0.001")))
    np.testing.assert_allclose(extents(mm), (0.001, 0.002, 0.003))
    # pycollada drops a geometry whose material is missing; the triangles still load
    broken = Mesh(str(box_dae(tmp_path, "broken.dae", broken_material=True)))
    np.testing.assert_allclose(extents(broken), (1, 2, 3))


def test_unreadable_meshes_are_model_errors(tmp_path: Path) -> None:
    (tmp_path / "a.mesh").write_text("ogre")
    with pytest.raises(ModelError, match=r"format '\.mesh' is not supported"):
        load_mesh(Mesh(str(tmp_path / "a.mesh")))
    (tmp_path / "empty.obj").write_text("# nothing\n")
    with pytest.raises(ModelError, match="holds no triangles"):
        load_mesh(Mesh(str(tmp_path / "empty.obj")))
    with pytest.raises(ModelError, match=r"missing\.stl"):
        load_mesh(Mesh(str(tmp_path / "missing.stl")))


def signed_volume(data) -> float:
    a, b, c = (data.vertices[data.faces[:, i]] for i in range(3))
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def test_mirroring_scale_keeps_the_mesh_outside_out(cube_stl: Path) -> None:
    plain = load_mesh(Mesh(str(cube_stl)))
    mirrored = load_mesh(Mesh(str(cube_stl), (1.0, -1.0, 1.0)))
    assert signed_volume(plain) == pytest.approx(0.006)
    assert signed_volume(mirrored) == pytest.approx(0.006)


def test_info_passes_xacro_arguments(tmp_path: Path, capsys) -> None:
    path = tmp_path / "one.urdf.xacro"
    path.write_text(
        '<robot name="one" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<link name="$(arg base)"/></robot>'
    )
    assert cli_main(["info", "--robot", str(path), "--xacro-arg", "base:=chassis", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["root"] == "chassis"
    assert cli_main(["info", "--robot", str(path)]) == 1
    err = capsys.readouterr().err
    assert "xacro expansion failed" in err and "base" in err


def test_repeated_materials() -> None:
    same = robot(
        '<material name="k"><color rgba="0 0 0 1"/></material>\n'
        '<material name="k"><color rgba="0 0 0 1"/></material>\n<link name="a"/>'
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error", URDFRepairWarning)
        assert urdf_from_string(same).materials["k"].rgba == (0.0, 0.0, 0.0, 1.0)
    other = same.replace(
        '<color rgba="0 0 0 1"/></material>\n<link', '<color rgba="1 1 1 1"/></material>\n<link'
    )
    m = repaired(other, "material 'k' (line 4) is defined again with other values")
    assert m.materials["k"].rgba == (0.0, 0.0, 0.0, 1.0)
    refused(robot('<material><color rgba="0 0 0 1"/></material><link name="a"/>'), "has no name")


def test_revolute_with_zero_range_is_opened() -> None:
    text = two_links(
        '<joint name="j" type="revolute"><parent link="base"/><child link="arm"/>'
        '<limit lower="0" upper="0" effort="0" velocity="0"/></joint>'
    )
    lim = repaired(text, "joint 'j' (line 5): revolute joint with range [0, 0]").joint("j").limit
    assert (lim.lower, lim.upper) == (-math.pi, math.pi)


def test_xacro_find_of_unknown_package(tmp_path: Path) -> None:
    path = tmp_path / "r.urdf.xacro"
    path.write_text(
        '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:include filename="$(find ghost_description)/urdf/parts.xacro"/>'
        '<link name="a"/></robot>'
    )
    with pytest.raises(ModelError, match=r"\$\(find ghost_description\): package not found"):
        load_urdf(path)


def test_small_but_valid_inertia_is_left_alone() -> None:
    text = two_links(
        child_extra='<inertial><mass value="0.3"/><inertia ixx="2e-8" iyy="2e-8" izz="3e-8"/>'
        "</inertial>"
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error", URDFRepairWarning)
        i = urdf_from_string(text).link("arm").inertial
    assert (i.ixx, i.iyy, i.izz) == (2e-8, 2e-8, 3e-8)
