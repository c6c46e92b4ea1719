"""Corpus: every URDF (and stand-alone xacro) shipped by example-robot-data loads, or
fails with a ModelError that says why; at least 95 % load, and their collision meshes read."""

from __future__ import annotations

from robotrial.geometry import Mesh
from robotrial.model.meshes import read_mesh_file
from robotrial.model.robot import ModelError


def test_example_robot_data_corpus_loads(example_robot_data) -> None:
    root = example_robot_data.root
    loaded, refused = example_robot_data.models, example_robot_data.refused
    total = len(loaded) + len(refused)
    assert total >= 60, f"only {total} description files under {root}"
    for path, msg in refused.items():
        assert str(path) in msg, msg  # a refusal says which file, and why
    for model in loaded.values():
        assert model.links and model.root
        for r in model.repairs:
            assert "link" in r or "joint" in r or "xacro" in r, r
    share = len(loaded) / total
    print(f"\nexample-robot-data: {len(loaded)} of {total} files load ({share:.1%})")
    for path, msg in refused.items():
        print(f"  refused {path.relative_to(root)}: {msg}")
    assert share >= 0.95, "\n".join(refused.values())


def test_example_robot_data_collision_meshes_read(example_robot_data) -> None:
    """Every collision mesh (STL, DAE, OBJ) of the corpus robots reads into triangles."""
    loaded = example_robot_data.models
    files = {
        c.geometry.filename
        for model in loaded.values()
        for link in model.links
        for c in link.collisions
        if isinstance(c.geometry, Mesh)
    }
    assert len(files) >= 300
    bad = []
    for f in sorted(files):
        try:
            data = read_mesh_file(f)
        except ModelError as exc:
            bad.append(str(exc))
            continue
        assert len(data.faces) > 0 and data.faces.max() < len(data.vertices)
    print(f"\nexample-robot-data: {len(files) - len(bad)} of {len(files)} collision meshes read")
    assert not bad, "\n".join(bad)
