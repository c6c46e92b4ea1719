"""Uploading your own robot through the page: a zip of a URDF with an STL mesh (made by
trimesh here) becomes a robot in the picker and opens; a broken URDF is refused with a
message naming the file, the line and the element, and the page keeps working. The
server's refusals (size, zip-slip) through FastAPI's TestClient."""

from __future__ import annotations

import io
import zipfile
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
import trimesh
from fastapi.testclient import TestClient
from playwright.sync_api import Page, sync_playwright

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


@pytest.mark.browser
def test_upload_good_and_broken_robot(
    server: str, chromium: str, chromium_args: list[str], artifacts: Path, tmp_path: Path
) -> None:
    good = tmp_path / "tower.zip"
    good.write_bytes(tower_zip())
    broken = tmp_path / "broken.urdf"
    broken.write_text(URDF.replace('<child link="boom"/>', '<child link="bom"/>'))
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=chromium, args=chromium_args)
        page = browser.new_page(viewport={"width": 1280, "height": 800})
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(server)
        wait_ready(page, "desk_arm")

        page.set_input_files("#robot-upload", str(good))
        page.wait_for_selector("#upload-message[data-status='ready']", timeout=30_000)
        state = wait_ready(page, "tower_arm")
        assert state["joints"]["names"] == ["swing"]
        assert state["world"] == "desk"
        assert page.locator("#robot-picker option[value='tower_arm']").count() == 1
        assert "tower_arm" in page.locator("#upload-message").inner_text()
        page.screenshot(path=artifacts / "web_upload_good.png")
        catalog = httpx.get(server + "api/robots").json()["robots"]
        assert {"name": "tower_arm", "uploaded": True}.items() <= next(
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
        browser.close()


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
