"""Descriptions loaded confined to their folder (what the server does with uploads) cannot
read the server's environment or files; each refusal names the file, the line and the
substitution or path. The same files on the command line keep xacro's full behaviour.
And the slips ROS's parser lets pass (XML version 0.0, two shapes in a <geometry>, an
unexpanded $(optenv)) load with a repair."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import trimesh

from robotrial.model import ModelError, load_robot

XACRO = '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">\n{}\n</robot>\n'
URDF = (
    '<robot name="r">\n<link name="base"><visual><geometry>{}</geometry></visual></link>\n'
    "</robot>\n"
)


def _write(folder: Path, name: str, text: str) -> Path:
    path = folder / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def _confined(folder: Path, name: str, text: str):
    path = _write(folder, name, text)
    return load_robot(path, package_paths=[folder], confined=folder)


@pytest.fixture
def upload(tmp_path: Path) -> Path:
    folder = tmp_path / "upload"
    folder.mkdir()
    (tmp_path / "secret.stl").write_bytes(trimesh.creation.box().export(file_type="stl"))
    (tmp_path / "secret.xacro").write_text(XACRO.format('<link name="stolen"/>'))
    (tmp_path / "secret.yaml").write_text("token: s3cret\n")
    return folder


REFUSED = [
    ('<link name="$(env HOME)"/>', "r.xacro:2: $(env HOME): uploaded descriptions may not read"),
    ('<link name="a${1}$(env PATH)"/>', "r.xacro:2: $(env PATH)"),
    ('<link name="$(find secret)"/>', "r.xacro:2: $(find secret): no such package inside"),
    ('<link name="$(cwd)"/>', "r.xacro:2: $(cwd): uploaded descriptions may not read"),
    ("<link name=\"$(eval [c for c in 'ab'])\"/>", "r.xacro:2: $(eval"),
    (
        "<link name=\"${xacro.load_yaml('../secret.yaml')}\"/>",
        "../secret.yaml: the file is outside",
    ),
    ("<link name=\"${xacro.abs_filename('x')}\"/>", "the attribute 'abs_filename' is not allowed"),
    ('<link name="${python.vars(math)}"/>', "the attribute 'vars' is not allowed"),
    ('<link name="${().__class__}"/>', "is not allowed"),
    ('<link name="${9**9**9}"/>', "r.xacro:2: ${9**9**9}: powers and shifts"),
    ("<link name=\"${'x' * 10}\"/>", "repeating text or lists is not allowed"),
    ('<xacro:include filename="/etc/hostname"/>', "r.xacro:2: /etc/hostname: the file is outside"),
    ('<xacro:include filename="../secret.xacro"/>', "r.xacro:2: ../secret.xacro: the file is"),
    ('<xacro:include filename="file:///etc/hostname"/>', "file:///etc/hostname: uploaded"),
    ('<xacro:include filename="package://secret/x.xacro"/>', "package://secret/x.xacro"),
]


@pytest.mark.parametrize(("line", "message"), REFUSED)
def test_xacro_substitutions_that_reach_the_server_are_refused(upload, line, message):
    with pytest.raises(ModelError) as err:
        _confined(upload, "r.xacro", XACRO.format(line))
    assert message in str(err.value)
    assert "stolen" not in str(err.value) and os.environ.get("HOME", "~") not in str(err.value)


MESHES = [
    ("file:///etc/passwd", "uploaded descriptions may name files only as package://"),
    ("/etc/passwd", "absolute paths are not allowed"),
    ("~/.bashrc", "absolute paths are not allowed"),
    ("../secret.stl", "the path leads outside the uploaded files"),
    ("meshes/../../secret.stl", "the path leads outside the uploaded files"),
    ("http://example.com/x.stl", "uploaded descriptions may name files only"),
]


@pytest.mark.parametrize(("filename", "message"), MESHES)
def test_mesh_paths_that_leave_the_upload_are_refused(upload, filename, message):
    with pytest.raises(ModelError) as err:
        _confined(upload, "r.urdf", URDF.format(f'<mesh filename="{filename}"/>'))
    text = str(err.value)
    assert "r.urdf:2: <mesh>: link 'base' visual 0" in text and message in text


def test_package_that_resolves_outside_the_upload_is_refused(upload, tmp_path):
    # A link inside the upload pointing outside it (zips refuse links; a folder may hold one)
    (upload / "pkg").symlink_to(tmp_path)
    with pytest.raises(ModelError, match=r"package://pkg/secret\.stl' refused: it leads outside"):
        _confined(upload, "r.urdf", URDF.format('<mesh filename="package://pkg/secret.stl"/>'))


def test_what_stays_inside_the_upload_loads(upload):
    _write(upload, "arm/package.xml", "<package><name>arm</name></package>")
    (upload / "arm" / "base.stl").write_bytes(trimesh.creation.box().export(file_type="stl"))
    _write(upload, "arm/limits.yaml", "reach: 0.4\n")
    _write(
        upload,
        "arm/parts.xacro",
        XACRO.format('<xacro:macro name="part"><link name="p"/></xacro:macro>'),
    )
    body = "\n".join(
        [
            '<xacro:include filename="$(find arm)/parts.xacro"/>',
            '<xacro:property name="cfg" value="${xacro.load_yaml(\'arm/limits.yaml\')}"/>',
            "<xacro:part/>",
            "<link name=\"l${int(cfg['reach'] * 10)}_$(optenv ROBOT_SUFFIX tip)\">",
            '<visual><geometry><mesh filename="package://arm/base.stl"/></geometry></visual>',
            "</link>",
            '<joint name="j" type="fixed"><parent link="p"/><child link="l4_tip"/></joint>',
        ]
    )
    os.environ["ROBOT_SUFFIX"] = "server_value"
    try:
        model = _confined(upload, "r.urdf.xacro", XACRO.format(body))
    finally:
        del os.environ["ROBOT_SUFFIX"]
    assert {link.name for link in model.links} == {"p", "l4_tip"}


def test_command_line_keeps_full_xacro(upload, monkeypatch):
    monkeypatch.setenv("ROBOT_SUFFIX", "from_env")
    path = _write(upload, "r.xacro", XACRO.format('<link name="$(env ROBOT_SUFFIX)"/>'))
    assert [link.name for link in load_robot(path).links] == ["from_env"]
    path = _write(
        upload, "m.urdf", URDF.format(f'<mesh filename="file://{upload.parent}/secret.stl"/>')
    )
    assert load_robot(path).links[0].visuals


def test_unexpanded_optenv_in_a_urdf_takes_its_default(tmp_path, monkeypatch):
    monkeypatch.setenv("HUSKY_IMU_XYZ", "9 9 9")
    text = URDF.format('<box size="1 1 1"/>').replace(
        "</robot>",
        '<link name="imu"/><joint name="j" type="fixed"><parent link="base"/>'
        '<child link="imu"/><origin xyz="$(optenv HUSKY_IMU_XYZ 0.19 0 0.149)"/></joint>\n'
        "</robot>",
    )
    path = _write(tmp_path, "husky.urdf", '<?xml version="1.0" encoding="utf-8"?>\n' + text)
    model = load_robot(path)
    assert tuple(model.joints[0].origin.xyz) == pytest.approx((0.19, 0, 0.149))
    assert any("$(optenv HUSKY_IMU_XYZ ...) was never expanded" in r for r in model.repairs)


@pytest.mark.parametrize(
    ("text", "repair"),
    [
        ('<?xml version="0.0" ?>\n' + URDF.format("<box size='1 1 1'/>"), "XML version '0.0'"),
        ('\n\n<?xml version="1.0"?>\n' + URDF.format("<box size='1 1 1'/>"), "blank lines"),
        (URDF.format("<box size='1 1 1'/>") + "\x00", "content after the closing </robot>"),
        (URDF.format("<box size='1 1 1'/><material name='m'/>"), "the first, <box>, is used"),
    ],
)
def test_xml_slips_that_ros_accepts_load_with_a_repair(tmp_path, text, repair):
    model = load_robot(_write(tmp_path, "r.urdf", text))
    assert any(repair in r for r in model.repairs), model.repairs


def test_xml_slips_are_not_hidden_errors(tmp_path):
    with pytest.raises(ModelError, match=r"r\.urdf:3: not well-formed XML"):
        load_robot(_write(tmp_path, "r.urdf", '<robot name="r">\n<link name="a">\n</robot>'))
    with pytest.raises(ModelError, match="<geometry> holds no shape"):
        load_robot(_write(tmp_path, "e.urdf", URDF.format("")))
