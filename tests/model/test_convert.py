"""`robotrial convert`: robots and worlds to RDTF/glTF and MJCF, as a user runs it."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import mujoco
import pygltflib
import pytest
import trimesh

from robotrial.cli import main
from robotrial.model import load_robot
from robotrial.model.rdtf import read_rdtf

from .rdtf_compare import model_differences

URDF = """<?xml version="1.0"?>
<robot name="tiny">
  <link name="base">
    <inertial><mass value="1.0"/><inertia ixx="0.01" iyy="0.01" izz="0.01"
      ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><mesh filename="package://tiny_description/meshes/part.stl"
      scale="0.001 0.001 0.001"/></geometry></visual>
  </link>
  <link name="arm">
    <inertial><mass value="0.5"/><inertia ixx="0.001" iyy="0.001" izz="0.001"
      ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><cylinder radius="0.02" length="0.2"/></geometry></visual>
    <collision><geometry><cylinder radius="0.02" length="0.2"/></geometry></collision>
  </link>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="arm"/><origin xyz="0 0 0.1" rpy="0 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="5" velocity="2"/>
  </joint>
</robot>
"""


def convert(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(["convert", *argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def tiny_urdf(tmp_path: Path) -> tuple[Path, Path]:
    """A URDF naming its mesh through package://, and the folder holding the package."""
    pkg_root = tmp_path / "pkgs"
    meshes = pkg_root / "tiny_description" / "meshes"
    meshes.mkdir(parents=True)
    trimesh.creation.box(extents=(100.0, 80.0, 20.0)).export(meshes / "part.stl")
    urdf = tmp_path / "elsewhere" / "tiny.urdf"
    urdf.parent.mkdir()
    urdf.write_text(URDF)
    return urdf, pkg_root


def test_builtin_robot_to_rdtf_prints_summary_and_round_trips(tmp_path, capsys):
    out = tmp_path / "arm.glb"
    code, stdout, _ = convert(capsys, "--robot", "desk_arm", "-o", str(out))
    assert code == 0
    model = load_robot("desk_arm")
    assert f"wrote {out} (RDTF" in stdout
    assert f"{len(model.links)} links, {len(model.joints)} joints" in stdout
    assert model_differences(model, read_rdtf(out)) == []


def test_urdf_with_package_path_to_rdtf_json(tiny_urdf, tmp_path, capsys):
    urdf, pkg_root = tiny_urdf
    out = tmp_path / "tiny.glb"
    code, stdout, _ = convert(
        capsys, "--robot", str(urdf), "-o", str(out), "-p", str(pkg_root), "--json"
    )
    assert code == 0
    result = json.loads(stdout)
    assert result["format"] == "RDTF" and result["links"] == 2 and result["joints"] == 1
    assert result["bytes"] == out.stat().st_size
    back = read_rdtf(out)
    mesh = back.link("base").visuals[0].geometry
    assert mesh.scale == (0.001, 0.001, 0.001)
    assert mesh.data.vertices.max() == pytest.approx(50.0)  # the file's own units


def test_rdtf_to_mjcf_compiles_in_mujoco(tiny_urdf, tmp_path, capsys):
    urdf, pkg_root = tiny_urdf
    glb = tmp_path / "tiny.glb"
    assert convert(capsys, "--robot", str(urdf), "-o", str(glb), "-p", str(pkg_root))[0] == 0
    xml = tmp_path / "mj" / "tiny.xml"
    xml.parent.mkdir()
    code, stdout, _ = convert(capsys, "--robot", str(glb), "-o", str(xml))
    assert code == 0 and "MJCF" in stdout
    m = mujoco.MjModel.from_xml_path(str(xml))
    assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "j1") >= 0
    assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "arm") >= 0


def test_world_to_glb_and_mjcf(tmp_path, capsys):
    glb = tmp_path / "room.glb"
    code, stdout, _ = convert(capsys, "--world", "room_b", "-o", str(glb), "--json")
    assert code == 0
    result = json.loads(stdout)
    assert result["kind"] == "world" and result["format"] == "glTF"
    names = {n.name for n in pygltflib.GLTF2.load(str(glb)).nodes}
    assert "floor" in names and any(n.startswith("wall/") for n in names)
    assert any(n.startswith("obstacle/") for n in names)
    xml = tmp_path / "room.xml"
    assert convert(capsys, "--world", "room_b", "-o", str(xml))[0] == 0
    m = mujoco.MjModel.from_xml_path(str(xml))
    assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor") >= 0


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--robot", "no_such_robot", "-o", "{tmp}/x.glb"], "unknown robot 'no_such_robot'"),
        (["--robot", "desk_arm", "-o", "{tmp}/x.obj"], "must end in .glb"),
        (["--robot", "desk_arm", "-o", "{tmp}/missing/x.glb"], "does not exist"),
        (["--robot", "{tmp}/broken.urdf", "-o", "{tmp}/x.glb"], "broken.urdf"),
        (["--world", "no_such_world", "-o", "{tmp}/x.glb"], "unknown world"),
        (["--robot", "{tmp}/junk.glb", "-o", "{tmp}/x.xml"], "not a glTF binary"),
    ],
)
def test_errors_are_one_line_and_exit_1(tmp_path, capsys, args, message):
    (tmp_path / "broken.urdf").write_text("<robot name='b'><link name='a'></robot>")
    (tmp_path / "junk.glb").write_bytes(b"nothing")
    code, stdout, stderr = convert(capsys, *(a.format(tmp=tmp_path) for a in args))
    assert code == 1 and stdout == ""
    assert stderr.startswith("robotrial convert: error:") and message in stderr
    assert stderr.count("\n") == 1


def test_the_installed_command_runs(tmp_path):
    out = tmp_path / "husky.glb"
    done = subprocess.run(
        [
            str(Path(sys.executable).parent / "robotrial"),
            "convert",
            "--robot",
            "husky",
            "-o",
            str(out),
            "--json",
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    assert json.loads(done.stdout)["name"] == "husky"
    assert out.read_bytes()[:4] == b"glTF"


XACRO = """<?xml version="1.0"?>
<robot name="stick" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:arg name="length" default="0.2"/>
  <link name="base"><visual><geometry>
    <cylinder radius="0.01" length="$(arg length)"/>
  </geometry></visual></link>
</robot>
"""


def test_xacro_arguments_reach_the_robot(tmp_path, capsys):
    src = tmp_path / "stick.urdf.xacro"
    src.write_text(XACRO)
    out = tmp_path / "stick.glb"
    assert (
        convert(capsys, "--robot", str(src), "-o", str(out), "--xacro-arg", "length:=0.5")[0] == 0
    )
    assert read_rdtf(out).link("base").visuals[0].geometry.length == 0.5
    code, _, err = convert(capsys, "--robot", str(src), "-o", str(out), "--xacro-arg", "length=0.5")
    assert code == 1 and "expected NAME:=VALUE" in err
