"""The web client's generated TypeScript (web/src/generated/) is committed: it must be
what its generators write from the Python models now, so a model changed without
regenerating fails here. Also what the API generator makes of the server's models, and
that the server's answers hold every property the generated types promise."""

from __future__ import annotations

from pathlib import Path
from types import ModuleType
from typing import Any

import pytest
from fastapi.testclient import TestClient

from robotrial.app import typescript as api_typescript
from robotrial.app.server import create_app
from robotrial.msgs import typescript as msgs_typescript

from tests.conftest import LOCAL

GENERATED = Path(__file__).resolve().parents[2] / "web" / "src" / "generated"


@pytest.fixture(scope="module")
def client() -> TestClient:
    return TestClient(create_app(warm=False), base_url=LOCAL)


@pytest.mark.parametrize(
    ("name", "generator"), [("msgs.ts", msgs_typescript), ("api.ts", api_typescript)]
)
def test_committed_files_match_their_generators(name: str, generator: ModuleType) -> None:
    committed = (GENERATED / name).read_text()
    assert committed == generator.generate(), (
        f"web/src/generated/{name} is stale: run "
        f"python -m {generator.__name__} web/src/generated/{name} and commit it"
    )


def test_api_types_follow_the_models() -> None:
    ts = api_typescript.generate()
    assert "/** What the page needs to start. */\nexport interface Config {" in ts
    assert "  live: LiveInfo | null;" in ts
    assert "  rosbridge: string;\n  /** Whether this server offers rosbridge there. */" in ts
    assert "  xyz: [number, number, number];" in ts
    assert "  quat: [number, number, number, number];" in ts
    assert '  kind: "arm" | "mobile";' in ts
    assert "  assets: Record<string, string>;" in ts
    assert "  robots: RobotEntry[];" in ts
    # Fields with a default are always sent, so they are not optional.
    assert "  uploaded: boolean;" in ts
    assert "?:" not in ts
    for name in api_typescript.schema():
        assert f"export interface {name} {{" in ts


def test_schema_constructs_and_refusals() -> None:
    nullable_strings = {"type": "array", "items": {"anyOf": [{"type": "string"}, {"type": "null"}]}}
    assert api_typescript.ts_type(nullable_strings) == "(string | null)[]"
    assert api_typescript.ts_type({"const": "arm"}) == '"arm"'
    assert api_typescript.ts_type({}) == "unknown"
    with pytest.raises(ValueError, match="no TypeScript type"):
        api_typescript.ts_type({"not": {"type": "string"}})
    with pytest.raises(ValueError, match="outside"):
        api_typescript.ts_type({"$ref": "https://example.org/schema.json"})
    assert api_typescript.main([]) == 2


def test_generator_writes_the_file(tmp_path: Path) -> None:
    out = tmp_path / "deep" / "api.ts"
    assert api_typescript.main([str(out)]) == 0
    assert out.read_text() == api_typescript.generate()


def _holds_every_property(value: Any, node: dict, defs: dict, where: str) -> None:
    """`value` (an answer's JSON) has exactly the properties its schema `node` lists,
    at every depth."""
    if "$ref" in node:
        model = defs[node["$ref"].removeprefix(api_typescript.REF_PREFIX)]
        assert set(value) == set(model["properties"]), where
        for field, prop in model["properties"].items():
            _holds_every_property(value[field], prop, defs, f"{where}.{field}")
    elif node.get("type") == "array" and "items" in node:
        for i, item in enumerate(value):
            _holds_every_property(item, node["items"], defs, f"{where}[{i}]")
    elif "anyOf" in node and value is not None:
        for choice in node["anyOf"]:
            if "$ref" in choice:
                _holds_every_property(value, choice, defs, where)


@pytest.mark.parametrize(
    ("path", "model"),
    [
        ("/api/config", "Config"),
        ("/api/robots", "RobotList"),
        ("/api/worlds", "WorldList"),
        ("/api/robots/desk_arm/mjcf.json", "MjcfBundle"),
    ],
)
def test_answers_hold_every_generated_property(client: TestClient, path: str, model: str) -> None:
    defs = api_typescript.schema()
    assert all(set(d["required"]) == set(d["properties"]) for d in defs.values())
    response = client.get(path)
    assert response.status_code == 200
    _holds_every_property(response.json(), {"$ref": api_typescript.REF_PREFIX + model}, defs, path)
