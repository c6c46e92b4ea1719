"""The web server's HTTP routes, through FastAPI's TestClient (no browser)."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient

from robotrial.app.server import STATIC_DIR, create_app
from robotrial.cli import main
from robotrial.model.robot import ModelError
from robotrial.ros.bus import Bus

from tests.conftest import LOCAL


@pytest.fixture(scope="module")
def client() -> TestClient:
    return TestClient(create_app(warm=False), base_url=LOCAL)


def test_config_names_the_default_pair_and_rosbridge_path(client: TestClient) -> None:
    body = client.get("/api/config").json()
    assert body["robot"] == "desk_arm"
    assert body["world"] == "desk"
    assert body["rosbridge"] == "/rosbridge"


def test_robot_list_gives_kinds_and_the_world_each_opens_in(client: TestClient) -> None:
    body = client.get("/api/robots").json()
    robots = {r["name"]: r for r in body["robots"]}
    assert {"desk_arm", "manipulator_h", "husky", "mobile_manipulator"} <= set(robots)
    assert robots["desk_arm"]["kind"] == "arm"
    assert robots["desk_arm"]["world"] == "desk"
    assert robots["mobile_manipulator"]["kind"] == "mobile"
    assert robots["mobile_manipulator"]["world"] == "room_a"
    assert robots["desk_arm"]["joints"] == 7
    assert body["default"] == {"robot": "desk_arm", "world": "desk"}


def test_world_list_gives_kinds_and_spawn_poses(client: TestClient) -> None:
    body = client.get("/api/worlds").json()
    worlds = {w["name"]: w for w in body["worlds"]}
    assert {"desk", "room_a", "room_b", "room_c", "apartment"} <= set(worlds)
    assert worlds["desk"]["kind"] == "arm"
    for room in ("room_a", "room_b", "room_c", "apartment"):
        assert worlds[room]["kind"] == "mobile"
    assert len(worlds["room_a"]["spawn"]["xyz"]) == 3
    assert len(worlds["room_a"]["spawn"]["quat"]) == 4
    assert body["default"] == {"robot": "desk_arm", "world": "desk"}


@pytest.mark.parametrize("path", ["/api/robots/desk_arm.glb", "/api/worlds/desk.glb"])
def test_files_are_gltf_binary_and_revalidate_by_etag(client: TestClient, path: str) -> None:
    first = client.get(path)
    assert first.status_code == 200
    assert first.headers["content-type"] == "model/gltf-binary"
    assert first.content[:4] == b"glTF"
    again = client.get(path, headers={"If-None-Match": first.headers["etag"]})
    assert again.status_code == 304


@pytest.mark.parametrize(
    ("path", "words"),
    [
        ("/api/robots/nobody.glb", ["unknown robot 'nobody'", "desk_arm"]),
        ("/api/worlds/mars.glb", ["unknown world 'mars'", "room_a"]),
    ],
)
def test_unknown_names_get_404_naming_the_built_ins(
    client: TestClient, path: str, words: list[str]
) -> None:
    response = client.get(path)
    assert response.status_code == 404
    for word in words:
        assert word in response.json()["detail"]


@pytest.mark.parametrize(
    "path",
    [
        "/api/robots/..%2F..%2F..%2Fpyproject.glb",
        "/api/robots/%2e%2e.glb",
        "/api/worlds/..%2Fdesk.glb",
        "/api/robots/desk_arm%2F..%2F..%2Fdesk_arm.glb",
        "/assets/..%2Fserver.py",
        "/assets/%2e%2e/%2e%2e/server.py",
        "/assets/..%2F..%2Fapp%2Fserver.py",
    ],
)
def test_path_traversal_is_refused(client: TestClient, path: str) -> None:
    response = client.get(path)
    assert response.status_code == 404
    assert b"create_app" not in response.content
    assert b"glTF" not in response.content[:4]


def test_page_is_served_from_the_build(client: TestClient) -> None:
    assert (STATIC_DIR / "index.html").is_file(), "run `make web` first"
    response = client.get("/")
    assert response.status_code == 200
    assert 'id="view"' in response.text
    script = response.text.split('src="', 1)[1].split('"', 1)[0]
    assert script.startswith("/assets/")
    assert client.get(script).status_code == 200


def test_missing_build_says_how_to_build_and_is_served_once_built(tmp_path) -> None:
    client = TestClient(create_app(static_dir=tmp_path, warm=False), base_url=LOCAL)
    response = client.get("/")
    assert response.status_code == 503
    assert "make web" in response.text
    assert client.get("/assets/main.js").status_code == 404
    (tmp_path / "assets").mkdir()
    (tmp_path / "assets" / "main.js").write_text("// built")
    (tmp_path / "index.html").write_text('<div id="view"></div>')
    assert client.get("/").status_code == 200
    assert client.get("/assets/main.js").text == "// built"


def test_unknown_default_robot_is_refused_at_start() -> None:
    with pytest.raises(ModelError, match="unknown robot 'r2d2'"):
        create_app(robot="r2d2", warm=False)


def test_openapi_lists_the_routes(client: TestClient) -> None:
    paths = client.get("/openapi.json").json()["paths"]
    for path in (
        "/api/config",
        "/api/robots",
        "/api/worlds",
        "/api/robots/{name}.glb",
        "/api/worlds/{name}.glb",
    ):
        assert path in paths


def test_rosbridge_is_mounted_when_a_bus_is_given() -> None:
    bus = Bus()
    heard: list = []
    bus.subscribe("/chatter", heard.append, "std_msgs/String")
    client = TestClient(create_app(bus=bus, warm=False), base_url=LOCAL)
    assert client.get("/api/config").json()["rosbridge_enabled"] is True
    with client.websocket_connect("ws://127.0.0.1/rosbridge") as ws:
        ws.send_json({"op": "advertise", "topic": "/chatter", "type": "std_msgs/String"})
        ws.send_json({"op": "publish", "topic": "/chatter", "msg": {"data": "hello"}})
        # Ops run in order: once this answer arrives, the publish has been delivered.
        ws.send_json({"op": "call_service", "service": "/rosapi/topics", "id": "t"})
        assert ws.receive_json()["op"] == "service_response"
    assert [m.data for m in heard] == ["hello"]


def test_no_rosbridge_route_without_a_bus(client: TestClient) -> None:
    assert client.get("/api/config").json()["rosbridge_enabled"] is False
    assert client.get("/rosbridge").status_code == 404


def test_serve_refuses_an_unknown_world(capsys) -> None:
    assert main(["serve", "--world", "atlantis"]) == 2
    assert "unknown world 'atlantis'" in capsys.readouterr().err
