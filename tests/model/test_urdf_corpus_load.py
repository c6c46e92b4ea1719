"""Corpus: every URDF (and stand-alone xacro) shipped by example-robot-data loads, or
fails with a ModelError that says why; at least 95 % load."""

from __future__ import annotations

import warnings
from importlib.metadata import PackageNotFoundError, distribution
from pathlib import Path

import pytest

from robotrial.model.robot import ModelError
from robotrial.model.urdf import load_urdf


def corpus_root() -> Path:
    """The robots folder the example-robot-data wheel installs (a cmeel prefix)."""
    try:
        dist = distribution("example-robot-data")
    except PackageNotFoundError:
        pytest.fail("example-robot-data is not installed (it is a dev dependency)")
    root = Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots")))
    assert root.is_dir(), f"example-robot-data has no robots folder at {root}"
    return root


def corpus_files() -> list[Path]:
    root = corpus_root()
    return sorted(root.rglob("*.urdf")) + sorted(root.rglob("*.xacro"))


def test_example_robot_data_corpus_loads() -> None:
    root = corpus_root()
    files = corpus_files()
    assert len(files) >= 60, f"only {len(files)} description files under {root}"
    loaded, failed = [], []
    for path in files:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                model = load_urdf(path)
            except ModelError as exc:
                # a refusal must say where and why
                assert str(path) in str(exc), str(exc)
                failed.append(f"{path.relative_to(root)}: {exc}")
                continue
        assert model.links and model.root
        for r in model.repairs:
            assert r.strip() and ("link" in r or "joint" in r or "xacro" in r), r
        loaded.append(path)
    share = len(loaded) / len(files)
    print(f"\nexample-robot-data: {len(loaded)} of {len(files)} files load ({share:.1%})")
    for f in failed:
        print(f"  refused: {f}")
    assert share >= 0.95, "\n".join(failed)
