"""The MJCF the page's physics loads: /api/robots/NAME/mjcf.json through FastAPI's
TestClient, compiled by MuJoCo in Python (the browser runs the same engine)."""

from __future__ import annotations

import base64

import mujoco
import pytest
from fastapi.testclient import TestClient

from robotrial.app.server import create_app

from tests.conftest import LOCAL


@pytest.fixture(scope="module")
def client() -> TestClient:
    return TestClient(create_app(warm=False), base_url=LOCAL)


def test_desk_arm_mjcf_compiles_with_servos_and_a_tcp_site(client: TestClient, tmp_path) -> None:
    response = client.get("/api/robots/desk_arm/mjcf.json", params={"world": "desk"})
    assert response.status_code == 200
    body = response.json()
    assert set(body) == {"name", "xml", "assets", "notes"}
    for name, data in body["assets"].items():
        (tmp_path / name).write_bytes(base64.b64decode(data))
    (tmp_path / "scene.xml").write_text(body["xml"])
    model = mujoco.MjModel.from_xml_path(str(tmp_path / "scene.xml"))
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "tcp") >= 0
    assert mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "obstacle/table_top") >= 0
    actuators = {model.actuator(i).name for i in range(model.nu)}
    assert {f"joint{i}" for i in range(1, 7)} <= actuators
    # Position servos: a gain on the control and a stiffness bias on the joint.
    arm = model.actuator("joint2")
    assert arm.gainprm[0] > 0 and arm.biasprm[1] == -arm.gainprm[0]


def test_default_world_etag_and_unknown_names(client: TestClient) -> None:
    first = client.get("/api/robots/desk_arm/mjcf.json")
    assert first.status_code == 200
    assert (
        first.json()["xml"] == client.get("/api/robots/desk_arm/mjcf.json?world=desk").json()["xml"]
    )
    again = client.get(
        "/api/robots/desk_arm/mjcf.json", headers={"If-None-Match": first.headers["etag"]}
    )
    assert again.status_code == 304
    missing = client.get("/api/robots/nope/mjcf.json")
    assert missing.status_code == 404 and "built-in robots are" in missing.json()["detail"]
    nowhere = client.get("/api/robots/desk_arm/mjcf.json?world=nowhere")
    assert nowhere.status_code == 404 and "built-in worlds are" in nowhere.json()["detail"]
