"""Worlds sent to the server (POST /api/worlds): every broken document is refused with
422 naming its entry, never 500; YAML budgets (aliases, nesting, counts) hold; a world
that is taken builds its files; a slow parse never holds the other requests."""

from __future__ import annotations

import math
import threading
import time

import httpx
import pytest
import yaml
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robotrial.app.server import create_app
from robotrial.model.world import MAX_ITEMS, MAX_YAML_DEPTH

from tests.conftest import LOCAL

ROOM = """
name: test room
floor: {size: [6, 6]}
walls:
  - {from: [-3, -3], to: [3, -3]}
  - {from: [3, -3], to: [3, 3]}
obstacles:
  - {name: table, shape: box, size: [1, 0.6, 0.7], pose: {xyz: [1, 0, 0.35]}}
"""


@pytest.fixture(scope="module")
def client() -> TestClient:
    return TestClient(create_app(warm=False), base_url=LOCAL)


def post(client: TestClient, text: str) -> httpx.Response:
    return client.post("/api/worlds", content=text.encode())


def test_a_good_world_is_taken_and_its_scene_builds(client: TestClient) -> None:
    r = post(client, ROOM)
    assert r.status_code == 201, r.text
    name = r.json()["name"]
    assert client.get(f"/api/worlds/{name}.glb").status_code == 200


@pytest.mark.parametrize(
    ("edit", "names"),
    [
        ("floor: {size: [6, 6], height: [1, 2]}", "floor.height"),
        ("spawns: [1, 2]", "spawns"),
        ("objects: [{name: cup, size: [0.1, 0.1, 0.1], mass: heavy}]", "objects[0].mass"),
        ("walls: [{from: [0, 0], to: [1, 0], thickness: -0.1}]", "walls[0].thickness"),
        ("walls: [{from: [0, 0], to: [1, 0], height: .nan}]", "walls[0].height"),
        ("obstacles: [{size: [1, .inf, 1]}]", "obstacles[0].size[1]"),
        ("obstacles: [{shape: cylinder, radius: 0, length: 1}]", "obstacles[0].radius"),
        ("lights: [{type: laser}]", "lights[0].type"),
        ("floor: [1, 2]", "floor"),
        ("home: {rooms: {a: 1}}", "home.rooms"),
        ("home: {rooms: [{corners: [[0, 0], [1, 0], [1, 1]]}], furniture: [5]}", "furniture[0]"),
    ],
)
def test_wrong_types_and_sizes_get_422_naming_the_entry(
    client: TestClient, edit: str, names: str
) -> None:
    r = post(client, f"name: broken\n{edit}\n")
    assert r.status_code == 422, r.text
    detail = r.json()["detail"]
    assert names in detail
    assert "np.float64" not in detail and "Traceback" not in detail


def test_aliases_are_refused_before_they_expand(client: TestClient) -> None:
    """A 300-byte alias chain would expand to gigabytes: refused by its line."""
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x]"]
    lines += [f"a{i}: &a{i} [*a{i - 1}, *a{i - 1}, *a{i - 1}]" for i in range(1, 12)]
    lines.append("description: *a11")
    r = post(client, "\n".join(lines))
    assert r.status_code == 422
    assert "aliases" in r.json()["detail"] and "line 2" in r.json()["detail"]


def test_deep_nesting_and_long_lists_are_refused(client: TestClient) -> None:
    deep = "description: " + "[" * (MAX_YAML_DEPTH + 5) + "]" * (MAX_YAML_DEPTH + 5)
    r = post(client, deep)
    assert r.status_code == 422 and "nested deeper" in r.json()["detail"]
    many = MAX_ITEMS["obstacles"] + 1
    boxes = "\n".join(f"  - {{name: b{i}, size: [0.1, 0.1, 0.1]}}" for i in range(many))
    r = post(client, f"obstacles:\n{boxes}\n")
    assert r.status_code == 422
    assert f"obstacles: {many} entries" in r.json()["detail"]


def test_the_world_list_stays_small_after_refusals(client: TestClient) -> None:
    before = len(client.get("/api/worlds").content)
    post(client, "description: " + "x" * 100_000)
    assert len(client.get("/api/worlds").content) == before


# --- generated documents ---------------------------------------------------------------

numbers = st.one_of(
    st.floats(-20, 20),
    st.integers(-3, 3),
    st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -1.0, 1e-12]),
)
anything = st.recursive(
    st.one_of(st.none(), st.booleans(), numbers, st.text(max_size=12)),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner),
    max_leaves=12,
)


def vec(n: int) -> st.SearchStrategy:
    return st.one_of(st.lists(numbers, min_size=n, max_size=n), anything)


def maybe(**fields: st.SearchStrategy) -> st.SearchStrategy:
    return st.one_of(st.fixed_dictionaries({}, optional=fields), anything)


pose = st.one_of(maybe(xyz=vec(3), rpy=vec(3), quat=vec(4)), vec(3))
body = maybe(
    name=st.text(max_size=6),
    shape=st.sampled_from(["box", "cylinder", "sphere", "mesh", "cone"]),
    size=vec(3),
    radius=numbers,
    length=numbers,
    pose=pose,
    rgba=vec(4),
    mass=st.one_of(numbers, st.just("heavy")),
)
wall = maybe(from_=vec(2), to=vec(2), thickness=numbers, height=numbers, name=st.text(max_size=6))
room = maybe(
    name=st.text(max_size=6), min=vec(2), max=vec(2), place=maybe(surface=anything, xy=vec(2))
)
home = maybe(
    thickness=numbers,
    rooms=st.lists(
        maybe(name=st.text(max_size=4), corners=st.lists(vec(2), max_size=5)), max_size=2
    ),
    doorways=st.lists(maybe(at=vec(2), width=numbers), max_size=2),
    furniture=st.lists(maybe(at=vec(2), size=vec(2), height=numbers, shape=anything), max_size=3),
)
world = st.fixed_dictionaries(
    {},
    optional={
        "name": st.one_of(st.text(max_size=8), anything),
        "floor": maybe(size=vec(2), center=vec(2), height=numbers, rgba=vec(4), friction=numbers),
        "wall_defaults": maybe(thickness=numbers, height=numbers),
        "walls": st.one_of(st.lists(wall, max_size=4), anything),
        "obstacles": st.one_of(st.lists(body, max_size=4), anything),
        "objects": st.one_of(st.lists(body, max_size=3), anything),
        "lights": st.one_of(
            st.lists(maybe(type=anything, intensity=numbers), max_size=2), anything
        ),
        "spawns": st.one_of(st.dictionaries(st.text(max_size=4), pose, max_size=2), anything),
        "interior": st.one_of(st.lists(vec(2), min_size=2, max_size=2), anything),
        "rooms": st.one_of(st.lists(room, max_size=2), anything),
        "home": home,
        "description": anything,
    },
)


def _yaml(doc: dict, share: bool) -> str:
    """The document as YAML; with `share`, one part appears twice, so that the YAML
    writer makes an anchor and an alias of it."""
    doc = {k.rstrip("_"): v for k, v in doc.items()}
    for key in ("walls", "obstacles", "objects"):
        items = doc.get(key)
        if isinstance(items, list):
            doc[key] = [
                {k.rstrip("_"): v for k, v in i.items()} if isinstance(i, dict) else i
                for i in items
            ]
    if share and doc:
        key = next(iter(doc))
        doc["description"] = doc[key]
    return yaml.safe_dump(doc, allow_unicode=True)


@settings(
    max_examples=300,
    deadline=1000,  # ms: no request of a generated world takes longer
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(doc=world, share=st.booleans())
def test_generated_worlds_are_taken_or_refused_in_words(
    client: TestClient, doc: dict, share: bool
) -> None:
    r = post(client, _yaml(doc, share))
    assert r.status_code in (201, 422), r.text
    if r.status_code == 201:
        name = r.json()["name"]
        glb = client.get(f"/api/worlds/{name}.glb")
        assert glb.status_code == 200, glb.text
    else:
        assert r.json()["detail"]


@settings(max_examples=100, deadline=1000)
@given(text=st.text(max_size=200))
def test_any_text_is_taken_or_refused_in_words(client: TestClient, text: str) -> None:
    assert post(client, text).status_code in (201, 422)


# --- the event loop ----------------------------------------------------------------


def test_a_large_world_does_not_hold_the_other_requests(serve) -> None:
    """While the server reads a world of two thousand boxes, /api/config keeps
    answering (the real server and client): a parse on the event loop would let at most
    the request already under way through before the world's answer."""
    url = serve()
    boxes = "\n".join(
        f"  - {{name: b{i}, size: [0.1, 0.1, 0.1], pose: {{xyz: [{i % 40}, {i // 40}, 0]}}}}"
        for i in range(2000)
    )
    big = f"name: many boxes\nobstacles:\n{boxes}\n"
    done: list[tuple[float, int]] = []

    def send_big() -> None:
        r = httpx.post(url + "api/worlds", content=big.encode(), timeout=60)
        done.append((time.monotonic(), r.status_code))

    sender = threading.Thread(target=send_big)
    sender.start()
    answered = []
    with httpx.Client(timeout=60) as http:
        while sender.is_alive() and len(answered) < 50:
            http.get(url + "api/config").raise_for_status()
            answered.append(time.monotonic())
    sender.join()
    assert done[0][1] == 201
    assert sum(t < done[0][0] for t in answered) >= 3
