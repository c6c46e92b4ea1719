"""Uploading your own robot through the page: a zip of a URDF with an STL mesh (made by
trimesh here) becomes a robot in the picker and opens; a broken URDF is refused with a
message naming the file, the line and the element, and the page keeps working. The
server's refusals (size, zip-slip) through FastAPI's TestClient."""

from __future__ import annotations

import io
import os
import subprocess
import sys
import zipfile
from collections.abc import Iterator
from pathlib import Path

import httpx
import numpy as np
import pytest
import trimesh
from fastapi.testclient import TestClient
from playwright.sync_api import Page

from robotrial.app.server import create_app

from tests.conftest import LOCAL

pytestmark = [pytest.mark.timeout(90)]

INERTIAL = (
    '<inertial><mass value="{m}"/><inertia ixx="0.01" iyy="0.01" izz="0.01"'
    ' ixy="0" ixz="0" iyz="0"/></inertial>'
)
URDF = f"""<?xml version="1.0"?>
<robot name="Tower Arm">
  <link name="base">
    <visual><geometry><mesh filename="package://tower/meshes/base.stl"/></geometry></visual>
    {INERTIAL.format(m=2.0)}
  </link>
  <link name="boom">
    <visual><origin xyz="0 0 0.2"/><geometry><box size="0.06 0.06 0.4"/></geometry></visual>
    {INERTIAL.format(m=0.5)}
  </link>
  <joint name="swing" type="revolute">
    <parent link="base"/><child link="boom"/><origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" effort="10" velocity="1"/>
  </joint>
</robot>
"""


def tower_zip() -> bytes:
    """The URDF and its STL base (a 0.3 x 0.3 x 0.1 m box), laid out as a ROS package."""
    stl = trimesh.creation.box((0.3, 0.3, 0.1)).export(file_type="stl")
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as z:
        z.writestr("tower/package.xml", "<package><name>tower</name></package>")
        z.writestr("tower/urdf/tower.urdf", URDF)
        z.writestr("tower/meshes/base.stl", stl)
    return out.getvalue()


@pytest.fixture(scope="module")
def server(serve) -> str:
    """`robotrial serve` (the desk arm)."""
    return serve()


def wait_ready(page: Page, robot: str) -> dict:
    page.wait_for_function(
        "(robot) => { const s = window.robotrial && window.robotrial.state();"
        " return s && (s.error || (s.ready && s.robot === robot)); }",
        arg=robot,
        timeout=30_000,
    )
    state = page.evaluate("window.robotrial.state()")
    assert state["error"] is None, state["error"]
    return state


def upload_on_page(browser, server: str, robot: Path) -> tuple[Page, list[str]]:
    """A new page on the desk arm that uploads `robot` and waits for the answer; the page
    and the list its errors go to."""
    page = browser.new_page(viewport={"width": 1280, "height": 800})
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(server)
    wait_ready(page, "desk_arm")
    page.set_input_files("#robot-upload", str(robot))
    page.wait_for_selector("#upload-message[data-status='ready']", timeout=60_000)
    return page, errors


@pytest.mark.browser
def test_upload_good_and_broken_robot(
    server: str, browser, artifacts: Path, tmp_path: Path
) -> None:
    good = tmp_path / "tower.zip"
    good.write_bytes(tower_zip())
    broken = tmp_path / "broken.urdf"
    broken.write_text(URDF.replace('<child link="boom"/>', '<child link="bom"/>'))
    page, errors = upload_on_page(browser, server, good)
    state = wait_ready(page, "tower_arm")
    assert state["joints"]["names"] == ["swing"]
    assert state["world"] == "desk"
    # listed under its name as the URDF writes it, not re-cased
    assert page.locator("#robot-picker option[value='tower_arm']").inner_text() == "Tower Arm"
    assert "Tower Arm" in page.locator("#upload-message").inner_text()
    page.screenshot(path=artifacts / "web_upload_good.png")
    catalog = httpx.get(server + "api/robots").json()["robots"]
    assert {"name": "tower_arm", "title": "Tower Arm", "uploaded": True}.items() <= next(
        r for r in catalog if r["name"] == "tower_arm"
    ).items()
    assert httpx.get(server + "api/robots/tower_arm.glb").content[:4] == b"glTF"

    page.set_input_files("#robot-upload", str(broken))
    page.wait_for_selector("#upload-message[data-status='error']", timeout=30_000)
    message = page.locator("#upload-message").inner_text()
    assert "broken.urdf:11" in message, message
    assert "swing" in message and "bom" in message, message
    page.screenshot(path=artifacts / "web_upload_broken.png")

    # The page keeps working: the uploaded robot is still shown and moves.
    state = wait_ready(page, "tower_arm")
    page.locator("input[data-joint='swing']").fill("1")
    page.wait_for_function("Math.abs(window.robotrial.state().joints.values[0] - 1) < 1e-6")
    page.select_option("#robot-picker", "desk_arm")
    wait_ready(page, "desk_arm")
    assert not errors, errors
    page.close()


# a plan refused, or a motion run to its end or stopped
ENDED = """() => { const s = window.robotrial.state();
    return (s.run && s.run.status !== 'moving')
        || ['refused', 'unreachable'].includes(s.planner.status); }"""


def ur5_zip() -> bytes:
    """example-robot-data's UR5 as a user zips its description package: the folder
    ur_description/ at the top, while the URDF asks for
    package://example-robot-data/robots/ur_description/... (one package folder off)."""
    from robotrial.benchmarks.arms import corpus_root

    package = corpus_root() / "ur_description"
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as z:
        z.write(package / "urdf" / "ur5_robot.urdf", "ur_description/urdf/ur5_robot.urdf")
        for f in sorted((package / "meshes" / "ur5").rglob("*")):
            z.write(f, str(f.relative_to(package.parent)))
    return out.getvalue()


def set_joints(page: Page, values: dict[str, float]) -> None:
    """Move joint sliders as a drag would (an input event per slider)."""
    page.evaluate(
        """(values) => { for (const [name, value] of Object.entries(values)) {
            const input = document.querySelector(`input[data-joint="${name}"]`);
            input.value = String(value);
            input.dispatchEvent(new Event('input', { bubbles: true })); } }""",
        values,
    )


@pytest.mark.browser
@pytest.mark.timeout(480)
def test_uploaded_ur5_shows_its_tool_and_moves_to_a_goal(
    server: str, browser, artifacts: Path, tmp_path: Path
) -> None:
    """The UR5 of example-robot-data, zipped one folder off: it loads (the mapping fixed
    and said), its read-out names tool0 and follows the sliders, and Move Robot! takes
    its hand to a goal from the upright pose the issue's users were refused at."""
    from robotrial.kinematics.chain import Kinematics
    from robotrial.model import load_robot

    from .test_experiment import type_into

    archive = tmp_path / "ur5.zip"
    archive.write_bytes(ur5_zip())
    page, errors = upload_on_page(browser, server, archive)
    assert "fixed automatically" in page.locator("#upload-message").inner_text()
    state = wait_ready(page, "ur5")
    assert page.locator("#robot-picker option[value='ur5']").inner_text() == "ur5"
    assert state["tool"] == "tool0"
    assert "tool0" in page.locator("#end-effector-link").inner_text()
    assert page.locator("#tool-picker").is_visible()

    from robotrial.benchmarks.arms import corpus_root

    model = load_robot(corpus_root() / "ur_description/urdf/ur5_robot.urdf")
    kin = Kinematics(model)
    upright = dict(zip(kin.joint_names, (0.0, -1.57, 1.57, -1.57, -1.57, 0.0), strict=True))
    set_joints(page, upright)
    hand = kin.link_pose(np.array(list(upright.values())))[:3, 3]
    page.wait_for_function(
        "(p) => { const e = window.robotrial.state().endEffector;"
        " return e && Math.hypot(e[0] - p[0], e[1] - p[1], e[2] - p[2]) < 1e-3; }",
        arg=hand.tolist(),
    )
    page.wait_for_function(
        "() => window.robotrial.state().connection.status === 'connected'", timeout=30_000
    )
    page.wait_for_selector("#move-robot:not([disabled])", timeout=30_000)
    goal = kin.link_pose(np.array([0.9, -1.2, 1.3, -1.67, -1.57, 0.0]))[:3, 3]
    page.locator("summary", has_text="Goal for the hand").click()
    for axis, value in zip("xyz", goal, strict=True):
        type_into(page, f"#goal-{axis}", round(float(value) * 100, 1))
    page.click("#set-robot")
    page.click("#move-robot")
    try:
        page.wait_for_function(ENDED, timeout=360_000)
    except Exception as exc:
        state = page.evaluate("window.robotrial.state()")
        raise AssertionError(
            f"no end within 6 minutes: {state['planner']}, {state['run']}"
        ) from exc
    state = page.evaluate("window.robotrial.state()")
    page.screenshot(path=artifacts / "web_upload_ur5_moved.png")
    page.close()
    assert state["planner"]["status"] == "planned", state["planner"]["message"]
    assert state["run"]["finalError"] <= 0.01, state["run"]
    np.testing.assert_allclose(state["endEffector"], goal, atol=0.01)
    assert not errors, errors


@pytest.fixture
def client(tmp_path: Path) -> Iterator[TestClient]:
    app = create_app(warm=False, uploads_dir=tmp_path / "uploads", max_upload_bytes=100_000)
    with TestClient(app, base_url=LOCAL) as c:
        yield c


def test_upload_too_large_gets_413(client: TestClient) -> None:
    r = client.post("/api/robots/upload", files={"file": ("big.urdf", b" " * 200_000)})
    assert r.status_code == 413
    assert "larger than" in r.json()["detail"] and "MB" in r.json()["detail"]


@pytest.mark.parametrize("entry", ["../evil.urdf", "/etc/evil.urdf", "a/../../evil.urdf"])
def test_zip_entries_never_leave_their_folder(
    client: TestClient, tmp_path: Path, entry: str
) -> None:
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as z:
        z.writestr(entry, URDF)
    r = client.post("/api/robots/upload", files={"file": ("evil.zip", out.getvalue())})
    assert r.status_code == 400
    assert "outside its folder" in r.json()["detail"]
    assert not (tmp_path / "evil.urdf").exists()
    assert not list((tmp_path / "uploads").rglob("*.urdf"))


def test_upload_by_http_then_rdtf_route(client: TestClient) -> None:
    r = client.post("/api/robots/upload", files={"file": ("tower.zip", tower_zip())})
    assert r.status_code == 201, r.text
    name = r.json()["robot"]["name"]
    assert name == "tower_arm"
    again = client.post("/api/robots/upload", files={"file": ("tower.zip", tower_zip())})
    assert again.json()["robot"]["name"] == "tower_arm_2"
    glb = client.get(f"/api/robots/{name}.glb")
    assert glb.status_code == 200 and glb.content[:4] == b"glTF"
    mjcf = client.get(f"/api/robots/{name}/mjcf.json")
    assert mjcf.status_code == 200 and "<mujoco" in mjcf.json()["xml"]
    # The RDTF file itself, and a xacro, are robots too.
    r = client.post("/api/robots/upload", files={"file": ("tower.glb", glb.content)})
    assert r.status_code == 201 and r.json()["robot"]["joints"] == 1, r.text
    xacro = URDF.replace(
        '<robot name="Tower Arm">',
        '<robot name="crane" xmlns:xacro="http://www.ros.org/wiki/xacro">'
        '<xacro:property name="reach" value="0.4"/>',
    ).replace('size="0.06 0.06 0.4"', 'size="0.06 0.06 ${reach}"')
    xacro = xacro.replace(
        '<mesh filename="package://tower/meshes/base.stl"/>', "<box size='0.3 0.3 0.1'/>"
    )
    r = client.post("/api/robots/upload", files={"file": ("crane.urdf.xacro", xacro.encode())})
    assert r.status_code == 201 and r.json()["robot"]["name"] == "crane", r.text
    r = client.post("/api/robots/upload", files={"file": ("notes.txt", b"hello")})
    assert r.status_code == 400 and ".zip" in r.json()["detail"]


def test_uploads_cannot_read_the_servers_environment_or_files(client: TestClient) -> None:
    env = (
        '<robot name="spy" xmlns:xacro="http://www.ros.org/wiki/xacro">\n'
        '<link name="$(env HOME)"/>\n</robot>\n'
    )
    r = client.post("/api/robots/upload", files={"file": ("spy.urdf.xacro", env.encode())})
    assert r.status_code == 422
    detail = r.json()["detail"]
    assert "spy.urdf.xacro:2: $(env HOME): uploaded descriptions may not read" in detail
    assert str(Path.home()) not in detail
    passwd = URDF.replace("package://tower/meshes/base.stl", "file:///etc/passwd")
    r = client.post("/api/robots/upload", files={"file": ("tower.urdf", passwd.encode())})
    assert r.status_code == 422
    assert (
        "tower.urdf:4: <mesh>: link 'base' visual 0: mesh 'file:///etc/passwd' refused"
        in (r.json()["detail"])
    )
    names = [robot["name"] for robot in client.get("/api/robots").json()["robots"]]
    assert "spy" not in names and "tower_arm" not in names


def test_a_zip_one_folder_off_is_mapped_and_said(client: TestClient) -> None:
    """The URDF asks for package://example-robot-data/robots/ur_description/... and the
    zip holds ur_description/ at its top: unambiguous, so it loads, and the answer says
    what was fixed; the robot keeps the name its authors wrote and finds its tool."""
    client.app.state.uploads.max_bytes = 20 * 2**20
    r = client.post("/api/robots/upload", files={"file": ("ur5.zip", ur5_zip())})
    assert r.status_code == 201, r.text
    answer = r.json()
    assert any("fixed automatically" in line for line in answer["repairs"]), answer["repairs"]
    robot = answer["robot"]
    assert (robot["name"], robot["title"], robot["tool"]) == ("ur5", "ur5", "tool0")
    assert robot["tools"][0] == "tool0" and "forearm_link" in robot["tools"]
    # another tool: the entry says so; a link that cannot be one is refused by name
    r = client.post("/api/robots/ur5/tool", json={"link": "wrist_3_link"})
    assert r.status_code == 200 and r.json()["tool"] == "wrist_3_link", r.text
    r = client.post("/api/robots/ur5/tool", json={"link": "base_link"})
    assert r.status_code == 422 and "not moved by an arm" in r.json()["detail"]
    assert client.post("/api/robots/desk_arm/tool", json={"link": "link3"}).status_code == 404


def test_missing_meshes_are_told_in_the_uploads_terms(client: TestClient, tmp_path: Path) -> None:
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as z:
        mesh = '<mesh filename="package://tower/meshes/base.stl"/>'
        z.writestr(
            "tower/urdf/tower.urdf",
            URDF.replace(
                f"<visual><geometry>{mesh}</geometry></visual>",
                f"<collision><geometry>{mesh}</geometry></collision>",
            ),
        )
    r = client.post("/api/robots/upload", files={"file": ("tower.zip", out.getvalue())})
    assert r.status_code == 422
    detail = r.json()["detail"]
    assert "tower.zip/tower/urdf/tower.urdf:4" in detail, detail
    assert "the upload has package 'tower' but no file tower/meshes/base.stl" in detail, detail
    assert "in the zip" in detail, detail
    assert "--package-path" not in detail and str(tmp_path) not in detail, detail


def _rss() -> int:
    """This process's resident memory (bytes)."""
    return int(Path("/proc/self/statm").read_text().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def test_too_many_triangles_are_refused_before_they_are_read(client: TestClient) -> None:
    """A mesh of 1.2 M triangles (a small zip: its faces repeat) is refused with its
    count and name, and the server's memory comes back to where it was."""
    faces = b"v 0 0 0\nv 1 0 0\nv 0 1 0\n" + b"f 1 2 3\n" * 1_200_000
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("tower/urdf/tower.urdf", URDF.replace("meshes/base.stl", "meshes/base.obj"))
        z.writestr("tower/meshes/base.obj", faces)
    data = out.getvalue()
    assert len(data) < 100_000
    before = _rss()
    r = client.post("/api/robots/upload", files={"file": ("tower.zip", data)})
    assert r.status_code == 413
    detail = r.json()["detail"]
    assert "1,200,000 triangles" in detail and "tower/meshes/base.obj" in detail, detail
    assert _rss() - before < 30 * 2**20
    assert not list(client.app.state.uploads.root.rglob("*.obj"))


def test_serve_takes_robot_and_world_files(tmp_path: Path) -> None:
    robot = tmp_path / "tower.urdf"
    robot.write_text(
        URDF.replace(
            '<mesh filename="package://tower/meshes/base.stl"/>', "<box size='0.3 0.3 0.1'/>"
        )
    )
    world = tmp_path / "corner.yaml"
    world.write_text("name: corner\nfloor: {size: [3, 3]}\n")
    app = create_app(str(robot), str(world), warm=False, uploads_dir=tmp_path / "uploads")
    with TestClient(app, base_url=LOCAL) as c:
        config = c.get("/api/config").json()
        assert (config["robot"], config["world"]) == ("tower_arm", "corner")
        entry = next(r for r in c.get("/api/robots").json()["robots"] if r["name"] == "tower_arm")
        assert entry["title"] == "Tower Arm"
    mistyped = subprocess.run(
        [Path(sys.executable).with_name("robotrial"), "serve", "--robot", "towr.urdf"]
        + ["--foxglove-port", "0"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert mistyped.returncode == 2
    said = (mistyped.stdout + mistyped.stderr).strip()
    assert said.splitlines() == ["error: towr.urdf: no such file"], said
