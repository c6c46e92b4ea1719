"""The layers of docs/architecture.md: a module imports only from its own layer or below,
and the robot side (`robotrial.onboard`) never imports the simulator or the world
description, where the truth lives."""

from __future__ import annotations

import ast
from pathlib import Path

import robotrial

PACKAGE = Path(robotrial.__file__).parent
LAYERS = {
    "geometry": 0,
    "msgs": 0,
    "console": 0,
    "gl": 0,
    "model": 1,
    "kinematics": 2,
    "collision": 2,
    "sim": 2,
    "planning": 3,
    "slam": 3,
    "nav": 3,
    "ros": 4,
    "onboard": 4,
    "cli": 5,
    "app": 5,
    "trials": 5,
    "benchmarks": 5,
}
TRUTH = ("robotrial.sim", "robotrial.model.world", "robotrial.trials", "robotrial.model.library")


def imports(path: Path) -> list[tuple[int, str]]:
    """(line, module) of every robotrial module a file imports, at any depth."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names if a.name.startswith("robotrial")]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module.startswith("robotrial"):
                out += [(node.lineno, node.module)]
                out += [(node.lineno, f"{node.module}.{a.name}") for a in node.names]
    return out


def area(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def test_every_module_imports_only_its_own_layer_or_below() -> None:
    wrong = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE)
        here = rel.parts[0].removesuffix(".py")
        if here not in LAYERS:
            continue
        for line, module in imports(path):
            there = area(module)
            if there in LAYERS and LAYERS[there] > LAYERS[here]:
                wrong.append(
                    f"{rel}:{line} (layer {LAYERS[here]}) imports {module} ({LAYERS[there]})"
                )
    assert not wrong, "\n".join(wrong)


def test_the_robot_side_imports_neither_the_simulator_nor_the_world() -> None:
    files = sorted((PACKAGE / "onboard").rglob("*.py"))
    assert len(files) >= 5
    wrong = [
        f"{p.relative_to(PACKAGE)}:{line} imports {module}"
        for p in files
        for line, module in imports(p)
        if module.startswith(TRUTH)
        or module in ("robotrial.model.load_world", "robotrial.model.World")
    ]
    assert not wrong, "\n".join(wrong)


def test_the_check_sees_a_forbidden_import(tmp_path: Path) -> None:
    bad = tmp_path / "bad.py"
    bad.write_text("from robotrial.sim.scene import SimWorld\nimport robotrial.model.world\n")
    assert [m for _, m in imports(bad) if m.startswith(TRUTH)] == [
        "robotrial.sim.scene",
        "robotrial.sim.scene.SimWorld",
        "robotrial.model.world",
    ]
