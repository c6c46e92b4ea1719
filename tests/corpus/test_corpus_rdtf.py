"""Corpus: every example-robot-data URDF that loads converts to RDTF that the Khronos
glTF validator accepts with no errors, and reads back equal to the loaded model."""

from __future__ import annotations

import json
import shutil
import subprocess
import warnings
from pathlib import Path

import pytest

from robotrial.model.rdtf import read_rdtf, write_rdtf

from ..model.rdtf_compare import model_differences

ROOT = Path(__file__).resolve().parents[2]
VALIDATOR = ROOT / "tools" / "validate_gltf.mjs"


def start_validator(paths: list[Path]) -> subprocess.Popen:
    """Start the Khronos validator (tools/validate_gltf.mjs) on all files at once; it
    runs while the round trips are checked."""
    node = shutil.which("node")
    assert node, "node is needed for the glTF validator"
    assert (ROOT / "tools" / "node_modules" / "gltf-validator").is_dir(), (
        "gltf-validator missing: run `make setup` (cd tools && npm ci)"
    )
    return subprocess.Popen(
        [node, str(VALIDATOR), *map(str, paths)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


@pytest.mark.slow
def test_every_loadable_urdf_converts_validates_and_round_trips(tmp_path, example_robot_data):
    urdfs = example_robot_data.urdfs
    assert len(urdfs) > 30, "example-robot-data ships more URDFs than found"
    written: dict[Path, Path] = {}
    models = {}
    not_loaded = [
        f"{u.name}: {example_robot_data.refused[u][:120]}"
        for u in urdfs
        if u in example_robot_data.refused
    ]
    for urdf in urdfs:
        if urdf not in example_robot_data.models:
            continue
        model = example_robot_data.models[urdf]
        out = tmp_path / f"{urdf.parent.parent.name}__{urdf.stem}.glb"
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            write_rdtf(model, out)
        written[urdf], models[urdf] = out, model
    validator = start_validator(list(written.values()))
    broken: list[str] = []
    for urdf, out in written.items():
        differences = model_differences(models[urdf], read_rdtf(out))
        if differences:
            broken.append(f"{urdf.name}: {differences[:3]}")
    stdout, stderr = validator.communicate()
    assert validator.returncode == 0, stderr
    reports = {r["file"]: r for r in json.loads(stdout)}
    invalid = []
    for urdf, out in written.items():
        errors = [m for m in reports[str(out)]["messages"] if m["severity"] in ("error", "warning")]
        if errors:
            invalid.append(f"{urdf.name}: {errors[:3]}")
    print(
        f"\nexample-robot-data: {len(urdfs)} URDFs, {len(written)} loaded and converted, "
        f"{len(written) - len(invalid)} valid glTF, {len(written) - len(broken)} round-trip "
        f"exactly; not loadable: {len(not_loaded)}"
    )
    for line in not_loaded:
        print("  not loaded:", line)
    assert not broken, "round trip lost fields:\n" + "\n".join(broken)
    assert not invalid, "validator errors or warnings:\n" + "\n".join(invalid)
    assert len(written) >= 0.9 * len(urdfs)
