"""POST /api/verdict and GET /api/verdict/{id} on the real `robotrial serve`: a home
checked for two robots in the background while the server keeps answering; the arm's
reach over a table in the answer; chores and the carry trial's answer to each; an unknown
robot, an arm without a base, broken YAML, a world without rooms, too many robots, a
chore naming an object or a room the home lacks, too many seeds and a body over the limit
are refused at once with the reason; a home whose outer wall has a gap fails its job
naming the room and the point; an unknown job id is a 404."""

from __future__ import annotations

import time

import httpx
import pytest

pytestmark = [pytest.mark.timeout(300)]


def home(east_wall_to: float = 3.0) -> str:
    """One 3 x 3 m room with the dock in the middle; its east wall runs from y = 0 to
    `east_wall_to` (3: closed)."""
    return f"""\
name: one_room
floor: {{size: [5.0, 5.0], center: [1.5, 1.5]}}
wall_defaults: {{thickness: 0.1, height: 1.0}}
walls:
  - {{name: south, from: [-0.05, 0.0], to: [3.05, 0.0]}}
  - {{name: north, from: [-0.05, 3.0], to: [3.05, 3.0]}}
  - {{name: west, from: [0.0, 0.0], to: [0.0, 3.0]}}
  - {{name: east, from: [3.0, 0.0], to: [3.0, {east_wall_to}]}}
rooms:
  - {{name: hall, min: [0.0, 0.0], max: [3.0, 3.0]}}
spawns:
  default: [1.5, 1.5, 0.0]
"""


CUP = (
    "objects:\n  - {name: cup, shape: cylinder, radius: 0.03, length: 0.1, mass: 0.15,"
    " pose: {xyz: [1.0, 1.0, 0.05]}}\n"
)


@pytest.fixture(scope="module")
def server(serve) -> str:
    return serve()


def finish(client: httpx.Client, job: dict, timeout: float = 240.0) -> dict:
    """Poll a job until it is done or failed; the server answers other routes meanwhile."""
    deadline = time.monotonic() + timeout
    seen = [job["fraction"]]
    while job["state"] not in ("done", "failed"):
        assert time.monotonic() < deadline, f"job still {job['state']}: {job['what']}"
        assert client.get("api/config").status_code == 200
        time.sleep(0.2)
        job = client.get(f"api/verdict/{job['id']}").json()
        seen.append(job["fraction"])
    assert seen == sorted(seen), f"progress went back: {seen}"
    return job


def test_a_home_is_checked_for_two_robots_in_the_background(server: str) -> None:
    with httpx.Client(base_url=server, timeout=30) as client:
        started = client.post(
            "api/verdict", json={"world": home(), "robots": ["husky", "mobile_manipulator"]}
        )
        assert started.status_code == 202, started.text
        assert started.json()["state"] in ("queued", "running")
        job = finish(client, started.json())
        assert job["state"] == "done", job["error"]
        assert job["fraction"] == 1.0 and job["world"] == "one_room"
        assert [r["robot"] for r in job["results"]] == ["husky", "mobile_manipulator"]
        for result in job["results"]:
            assert result["summary"].startswith("fits: 1 of 1 rooms"), result["summary"]
            assert [(r["room"], r["reachable"]) for r in result["rooms"]] == [("hall", True)]
            assert result["pictures"]["floor plan"].startswith("data:image/png;base64,")
            assert result["footprint"][1] == pytest.approx(0.67, abs=0.01)


def test_the_arm_reach_comes_with_the_verdict(server: str) -> None:
    """A table in the room: the mobile manipulator's answer carries what its hand reaches
    on it (the share, no heat-map points) and the reach pictures; the husky's says it has
    no arm."""
    table = (
        "obstacles:\n  - {name: table, kind: furniture, shape: box, size: [0.8, 0.6, 0.7],"
        " pose: {xyz: [1.5, 2.5, 0.35]}}\n"
    )
    with httpx.Client(base_url=server, timeout=30) as client:
        started = client.post(
            "api/verdict",
            json={"world": home() + table, "robots": ["mobile_manipulator", "husky"]},
        )
        assert started.status_code == 202, started.text
        job = finish(client, started.json())
        assert job["state"] == "done", job["error"]
        arm, base = job["results"]
        (top,) = arm["details"]["reach"]["surfaces"]
        assert top["surface"] == "table" and top["share"] > 0 and "heat_map" not in top
        assert "reaches: table" in arm["summary"]
        assert {"floor plan", "reach maps", "heights"} <= set(arm["pictures"])
        assert base["summary"] == "fits: 1 of 1 rooms; no arm: reach not checked"
        assert set(base["pictures"]) == {"floor plan"}


def test_chores_come_back_with_each_robots_verdict(server: str) -> None:
    """A chore the carry trial refuses (the hall has nowhere to set things down) comes
    back in the answer with the trial's reason, and counts in the summary."""
    with httpx.Client(base_url=server, timeout=30) as client:
        started = client.post(
            "api/verdict",
            json={
                "world": home() + CUP,
                "robots": ["mobile_manipulator"],
                "chores": [{"object": "cup", "to": "hall"}],
                "seeds": 2,
            },
        )
        assert started.status_code == 202, started.text
        job = finish(client, started.json())
        assert job["state"] == "done", job["error"]
        (result,) = job["results"]
        (chore,) = result["chores"]
        assert chore["chore"] == "cup:hall" and chore["runs"] == 0 and not chore["done"]
        assert "room 'hall' has no place to set things down" in chore["refused"]
        assert result["summary"].endswith("chores: 0 of 1")


@pytest.mark.parametrize(
    ("body", "status", "words"),
    [
        ({"world": home(), "robots": ["r2d2"]}, 422, ["unknown robot 'r2d2'", "husky"]),
        ({"world": home(), "robots": ["desk_arm"]}, 422, ["'desk_arm' has no mobile base"]),
        ({"world": "name: x\nwalls: [\n", "robots": ["husky"]}, 422, ["world YAML", "line 3"]),
        ({"world": "atlantis", "robots": ["husky"]}, 422, ["unknown world 'atlantis'"]),
        ({"world": "room_a", "robots": ["husky"]}, 422, ["'room_a' names no rooms"]),
        ({"world": home(), "robots": ["husky"] * 3}, 422, ["robots:", "at most 2"]),
        ({"world": home()}, 422, ["robots: Field required"]),
        ({"world": "x" * (1024 * 1024 + 1), "robots": ["husky"]}, 413, ["at most 1024 kB"]),
        (
            {"world": home(), "robots": ["husky"], "chores": [{"object": "teapot", "to": "hall"}]},
            422,
            ["chore teapot:hall", "no movable object 'teapot'", "none (add one"],
        ),
        (
            {
                "world": home() + CUP,
                "robots": ["husky"],
                "chores": [{"object": "cup", "to": "attic"}],
            },
            422,
            ["chore cup:attic", "no room 'attic'", "its rooms: hall"],
        ),
        ({"world": home(), "robots": ["husky"], "seeds": 9}, 422, ["seeds"]),
    ],
)
def test_bad_requests_are_refused_with_the_reason(
    server: str, body: dict, status: int, words: list[str]
) -> None:
    answer = httpx.post(server + "api/verdict", json=body, timeout=30)
    assert answer.status_code == status, answer.text
    for word in words:
        assert word in answer.json()["detail"]


def test_a_home_open_to_the_outside_fails_naming_the_room_and_the_gap(server: str) -> None:
    with httpx.Client(base_url=server, timeout=30) as client:
        started = client.post(
            "api/verdict", json={"world": home(east_wall_to=1.0), "robots": ["husky"]}
        )
        assert started.status_code == 202, started.text
        job = finish(client, started.json())
        assert job["state"] == "failed" and job["results"] == []
        assert "not closed" in job["error"] and "hall" in job["error"], job["error"]
        gap = job["error"].split("near (", 1)[1].split(")", 1)[0]
        x, y = (float(v) for v in gap.split(","))
        assert x == pytest.approx(3.0, abs=0.1) and 1.0 <= y <= 3.0, job["error"]


def test_an_unknown_job_is_a_404(server: str) -> None:
    answer = httpx.get(server + "api/verdict/0123abcd", timeout=30)
    assert answer.status_code == 404
    assert "no verdict job '0123abcd'" in answer.json()["detail"]
