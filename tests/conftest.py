"""Shared test fixtures: free loopback ports, Debian's Chromium, an artifacts folder, and
example-robot-data's robots loaded once for the whole session."""

from __future__ import annotations

import os
import shutil
import socket
import warnings
from dataclasses import dataclass, field
from importlib.metadata import PackageNotFoundError, distribution
from pathlib import Path

import pytest

from robotrial.gl import choose_gl_backend

ROOT = Path(__file__).resolve().parents[1]
ARTIFACTS = ROOT / "test-artifacts"
LOCAL = "http://127.0.0.1"
"""TestClient's base URL: a Host the server answers to (it refuses other names)."""
CHROMIUM = os.environ.get("ROBOTRIAL_CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--enable-unsafe-swiftshader",
]

choose_gl_backend()


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def port() -> int:
    return free_port()


@pytest.fixture(scope="session")
def artifacts() -> Path:
    ARTIFACTS.mkdir(exist_ok=True)
    return ARTIFACTS


@pytest.fixture(scope="session")
def chromium() -> str:
    """Path of Debian's Chromium; the browser tests need it (installed by .ci/run)."""
    path = shutil.which(CHROMIUM) or CHROMIUM
    if not Path(path).exists():
        pytest.fail(f"Chromium not found at {CHROMIUM}: install Debian's chromium (see .ci/run)")
    return path


@pytest.fixture(scope="session")
def chromium_args() -> list[str]:
    """CHROMIUM_ARGS for `launch(args=...)`, as a fixture: test modules cannot import conftest."""
    return list(CHROMIUM_ARGS)


@dataclass
class Corpus:
    """example-robot-data's description files (every *.urdf and *.xacro under `root`),
    each loaded once: the models that load, and the refusals' messages."""

    root: Path
    models: dict[Path, object] = field(default_factory=dict)
    refused: dict[Path, str] = field(default_factory=dict)

    @property
    def urdfs(self) -> list[Path]:
        return sorted(p for p in (*self.models, *self.refused) if p.suffix == ".urdf")


@pytest.fixture(scope="session")
def example_robot_data() -> Corpus:
    """The corpus loaded once per session (it was loaded three times across tests/corpus
    and tests/model): the robots folder the example-robot-data wheel installs."""
    from robotrial.model.robot import ModelError
    from robotrial.model.urdf import load_urdf

    try:
        dist = distribution("example-robot-data")
    except PackageNotFoundError:
        pytest.fail("example-robot-data is not installed (it is a dev dependency)")
    root = Path(str(dist.locate_file("cmeel.prefix/share/example-robot-data/robots")))
    assert root.is_dir(), f"example-robot-data has no robots folder at {root}"
    corpus = Corpus(root)
    for path in sorted(root.rglob("*.urdf")) + sorted(root.rglob("*.xacro")):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # repairs are checked by the loader's own tests
            try:
                corpus.models[path] = load_urdf(path)
            except ModelError as exc:
                corpus.refused[path] = str(exc)
    return corpus
