"""The command line when something is wrong or stops it: `--version`, a mistyped world
file in one line with exit 2, a busy Foxglove port named in the banner, and `serve`
ending within seconds of SIGTERM while verdict jobs run."""

from __future__ import annotations

import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest

from robotrial.model import library
from tests.conftest import free_port

ROBOTRIAL = str(Path(sys.executable).with_name("robotrial"))


def test_version() -> None:
    done = subprocess.run([ROBOTRIAL, "--version"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0
    assert done.stdout.startswith("robotrial ") and done.stdout.split()[1][0].isdigit()


@pytest.mark.parametrize("command", [["sim", "--duration", "1"], ["verdict"]])
def test_a_mistyped_world_file_is_one_line_and_exit_2(tmp_path: Path, command: list[str]) -> None:
    world = tmp_path / "home.yaml"
    world.write_text("name: home\nfloor: {size: [5, 5], height: [1, 2]}\n")
    done = subprocess.run(
        [ROBOTRIAL, *command, "--world", str(world)], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "floor.height: expected a number" in lines[0], done.stderr


def _serve(*args: str) -> tuple[subprocess.Popen, str]:
    port = free_port()
    proc = subprocess.Popen(
        [ROBOTRIAL, "serve", "--port", str(port), *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    url = f"http://127.0.0.1:{port}/"
    deadline = time.monotonic() + 60
    while True:
        try:
            httpx.get(url + "api/config", timeout=1).raise_for_status()
            return proc, url
        except httpx.HTTPError:
            assert proc.poll() is None, proc.stderr.read() if proc.stderr else ""
            assert time.monotonic() < deadline, "serve did not answer within 60 s"
            time.sleep(0.1)


def test_a_busy_foxglove_port_is_named_and_serve_goes_on() -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        busy = taken.getsockname()[1]
        proc, _ = _serve("--foxglove-port", str(busy))
        try:
            banner = proc.stdout.readline() + proc.stdout.readline()
        finally:
            proc.terminate()
            proc.wait(10)
    assert f"Foxglove is off: port {busy} is in use" in banner
    assert "--foxglove-port" in banner and "Foxglove at" not in banner


def test_sigterm_stops_serve_while_verdict_jobs_run() -> None:
    """Two checks of the apartment are running; SIGTERM ends the server at once (the
    jobs are discarded) with the shell's code for it, and no traceback."""
    proc, url = _serve("--foxglove-port", "0")
    home = library.world_path("apartment").read_text()
    for _ in range(2):
        r = httpx.post(
            url + "api/verdict", json={"world": home, "robots": ["mobile_manipulator"]}, timeout=30
        )
        assert r.status_code == 202, r.text
    time.sleep(1.0)  # both are under way
    asked = time.monotonic()
    proc.send_signal(signal.SIGTERM)
    try:
        code = proc.wait(timeout=5)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise AssertionError("serve was still running 5 s after SIGTERM") from None
    took = time.monotonic() - asked
    assert code == 128 + signal.SIGTERM, took
    assert "Traceback" not in proc.stderr.read()
