"""Homes drawn in the page: the world YAML the editor writes loads, runs in MuJoCo with a
robot, and is accepted by POST /api/worlds; a home with a doorway off its walls, too
narrow or too wide, overlapping furniture, an open room or a file reference is refused
with the item named, by the loader and by the server (422)."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import mujoco
import pytest
import yaml
from fastapi.testclient import TestClient

from robotrial.app.server import MAX_WORLD_BYTES, create_app
from robotrial.model import ModelError, load_robot, load_world
from robotrial.model.mjcf import to_mjcf
from robotrial.model.world import load_world_text
from tests.conftest import LOCAL

# What the editor writes for two 4 x 3 and 3 x 3 m rooms sharing the wall x = 4, with a
# 0.6 m doorway at (4, 1.5), a table and a cup on it.
PLAN = {
    "version": 1,
    "thickness": 0.1,
    "height": 2.0,
    "rooms": [
        {"name": "Room 1", "corners": [[0, 0], [4, 0], [4, 3], [0, 3]]},
        {"name": "Room 2", "corners": [[4, 0], [7, 0], [7, 3], [4, 3]]},
    ],
    "doorways": [{"name": "Doorway 1", "at": [4, 1.5], "width": 0.6}],
    "furniture": [
        {"name": "table", "shape": "box", "at": [5.5, 1.5], "size": [1.2, 0.8], "height": 0.75}
    ],
    "objects": [{"name": "cup", "at": [5.5, 1.5], "size": 0.08}],
    "spawn": None,
}
HOME = """\
name: "my_home"
floor: {size: [9, 5], center: [3.5, 1.5]}
interior: [[0.05, 0.05], [6.95, 2.95]]
wall_defaults: {thickness: 0.1, height: 2}
walls:
  - {name: wall1, from: [-0.05, 0], to: [7.05, 0]}
  - {name: wall2, from: [4, -0.05], to: [4, 1.2]}
  - {name: wall3, from: [4, 1.8], to: [4, 3.05]}
  - {name: wall4, from: [-0.05, 3], to: [7.05, 3]}
  - {name: wall5, from: [0, -0.05], to: [0, 3.05]}
  - {name: wall6, from: [7, -0.05], to: [7, 3.05]}
obstacles:
  - {name: "table", kind: furniture, shape: box, size: [1.2, 0.8, 0.75],
     pose: {xyz: [5.5, 1.5, 0.375]}}
objects:
  - {name: "cup", shape: box, size: [0.08, 0.08, 0.08], mass: 0.2, pose: {xyz: [5.5, 1.5, 0.79]}}
spawns:
  default: [2, 1.5, 0.0]
rooms:
  - {name: "Room 1", min: [0, 0], max: [4, 3]}
  - {name: "Room 2", min: [4, 0], max: [7, 3]}
"""


def home_yaml(**changes: object) -> str:
    plan = {**PLAN, **changes}
    return HOME + f"home: {json.dumps(plan)}\n"


def test_a_drawn_home_loads_from_a_file_and_runs_in_mujoco(tmp_path: Path) -> None:
    path = tmp_path / "my_home.yaml"
    path.write_text(home_yaml())
    world = load_world(path)
    assert [r.name for r in world.rooms] == ["Room 1", "Room 2"]
    assert world.spawn().xyz[:2] == (2.0, 1.5)
    model = mujoco.MjModel.from_xml_string(to_mjcf(load_robot("husky"), world).xml)
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 200)
    cup = data.body("object/cup").xpos
    assert cup[2] == pytest.approx(0.79, abs=0.01)  # it stays on the table


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        (
            {"doorways": [{"name": "Doorway 1", "at": [2, 1.4], "width": 0.6}]},
            "home.doorways[0] (Doorway 1): does not sit on a wall; the nearest wall "
            "(home.rooms[0] (Room 1) edge 1) is 1.40 m away",
        ),
        (
            {"doorways": [{"name": "Doorway 1", "at": [4, 1.5], "width": 0.05}]},
            "home.doorways[0] (Doorway 1): 0.05 m wide is narrower than the wall is thick",
        ),
        (
            {"doorways": [{"name": "Doorway 1", "at": [4, 1.5], "width": 3.5}]},
            "home.doorways[0] (Doorway 1): 3.50 m wide is wider than its wall",
        ),
        (
            {
                "furniture": [
                    *PLAN["furniture"],  # type: ignore[misc]
                    {
                        "name": "sofa",
                        "shape": "cylinder",
                        "at": [6, 2],
                        "size": [1, 1],
                        "height": 1,
                    },
                ]
            },
            "home.furniture[1] (sofa) overlaps home.furniture[0] (table)",
        ),
        (
            {"rooms": [{"name": "Hall", "corners": [[0, 0], [4, 0]]}]},
            "home.rooms[0] (Hall): not closed; a room needs at least 3 corners",
        ),
        (
            {"rooms": [{"name": "Hall", "corners": [[0, 0], [4, 0], [0, 3], [4, 3]]}]},
            "home.rooms[0] (Hall): edges 2 and 4 cross",
        ),
        (
            {"doorways": [{"name": "Doorway 1", "at": [4, 1.5], "width": "wide"}]},
            "home.doorways[0] (Doorway 1).width: expected a number, got 'wide'",
        ),
    ],
)
def test_a_bad_home_is_refused_naming_the_item(tmp_path: Path, changes: dict, message: str) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(home_yaml(**changes))
    with pytest.raises(ModelError) as err:
        load_world(path)
    assert message in str(err.value)
    assert str(path) in str(err.value)


def test_a_world_sent_to_the_server_may_not_refer_to_files() -> None:
    data = yaml.safe_load(home_yaml())
    data["obstacles"].append({"name": "secret", "shape": "mesh", "file": "/etc/passwd"})
    with pytest.raises(ModelError, match=r"obstacles\[1\]: a world sent to the server cannot"):
        load_world_text(yaml.safe_dump(data))


@pytest.fixture
def client(tmp_path: Path) -> Iterator[TestClient]:
    with TestClient(create_app(warm=False, uploads_dir=tmp_path / "uploads"), base_url=LOCAL) as c:
        yield c


def test_post_worlds_adds_the_home_to_the_catalog(client: TestClient) -> None:
    r = client.post("/api/worlds", content=home_yaml())
    assert r.status_code == 201, r.text
    assert r.json()["name"] == "my_home" and r.json()["kind"] == "mobile"
    again = client.post("/api/worlds", content=home_yaml())
    assert again.json()["name"] == "my_home_2"
    names = [w["name"] for w in client.get("/api/worlds").json()["worlds"]]
    assert names[-2:] == ["my_home", "my_home_2"]
    assert client.get("/api/worlds/my_home.glb").content[:4] == b"glTF"


def test_post_worlds_refuses_bad_homes_and_large_bodies(client: TestClient) -> None:
    bad = home_yaml(doorways=[{"name": "Door", "at": [2, 1.5], "width": 0.6}])
    r = client.post("/api/worlds", content=bad)
    assert r.status_code == 422
    assert "home.doorways[0] (Door): does not sit on a wall" in r.json()["detail"]
    r = client.post("/api/worlds", content="walls: [{from: [0, 0]}]")
    assert r.status_code == 422 and "walls[0]: a wall needs 'from' and 'to'" in r.json()["detail"]
    r = client.post("/api/worlds", content="name: [unclosed")
    assert r.status_code == 422 and "is not valid YAML" in r.json()["detail"]
    r = client.post("/api/worlds", content=b"#" * (MAX_WORLD_BYTES + 1))
    assert r.status_code == 413
    names = [w["name"] for w in client.get("/api/worlds").json()["worlds"]]
    assert "my_home" not in names
