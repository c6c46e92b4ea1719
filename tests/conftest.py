"""Shared test fixtures: free loopback ports, Debian's Chromium, an artifacts folder."""

from __future__ import annotations

import os
import shutil
import socket
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
